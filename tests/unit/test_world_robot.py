"""The robot's true body: true geometry, motors, slip and exact arcs."""

import math

import numpy as np
import pytest

from zenav.common.config import RobotConfig
from zenav.common.scenarios import PRESETS
from zenav.world import robot
from zenav.world.robot import State, World

R, TRACK, DT = 0.03365, 0.1156, 0.01
IDEAL = World(radius_left=R, radius_right=R, track=TRACK, motor_lag=0.0, deadband=0.0, motor_max=10.0, slip_sigma=0.0)


def drive(s, w, left, right, seconds, seed=1):
    rng = np.random.default_rng(seed)
    for _ in range(round(seconds / DT)):
        s = robot.step(s, w, left, right, DT, rng)
    return s


def test_true_geometry_of_the_scenarios():
    w = robot.world(RobotConfig(), PRESETS["default"])
    assert w.radius_left == pytest.approx(0.0673 / 2 * 1.003)
    assert w.radius_right == pytest.approx(0.0673 / 2 * 0.997)
    assert w.track == pytest.approx(0.1156 * 1.02)
    harsh = robot.world(RobotConfig(), PRESETS["harsh"])
    assert harsh.radius_left == pytest.approx(0.0673 / 2 * (1 + 0.01 - 0.005))
    assert harsh.radius_right == pytest.approx(0.0673 / 2 * (1 - 0.01 - 0.005))
    assert (harsh.motor_lag, harsh.deadband, harsh.slip_sigma) == (0.08, 1.0, 0.03)


def test_straight_line():
    s = drive(State(), IDEAL, 5.0, 5.0, 2.0)
    assert s.x == pytest.approx(R * 5.0 * 2.0)
    assert s.y == pytest.approx(0.0, abs=1e-12) and s.theta == pytest.approx(0.0, abs=1e-12)
    assert s.v == pytest.approx(R * 5.0) and s.omega == pytest.approx(0.0, abs=1e-12)
    assert s.angle_left == pytest.approx(10.0) and s.angle_right == pytest.approx(10.0)


def test_straight_line_along_the_heading():
    s = drive(State(x=1.0, y=-1.0, theta=math.pi / 2), IDEAL, 5.0, 5.0, 1.0)
    assert (s.x, s.y) == pytest.approx((1.0, -1.0 + R * 5.0))


def test_turn_in_place():
    s = drive(State(), IDEAL, -4.0, 4.0, 0.5)
    assert s.omega == pytest.approx(2 * R * 4.0 / TRACK)
    assert s.theta == pytest.approx(2 * R * 4.0 / TRACK * 0.5)
    assert math.hypot(s.x, s.y) < 1e-12 and s.v == pytest.approx(0.0, abs=1e-12)


def test_unequal_wheels_drive_an_exact_circle():
    # v = R*(4+8)/2, omega = R*(8-4)/TRACK: one lap takes 2 pi / omega.
    omega = R * 4.0 / TRACK
    lap = 2 * math.pi / omega
    dt = lap / 200  # whole number of steps per lap
    rng = np.random.default_rng(1)
    s = State()
    radius = (R * 6.0) / omega
    for _ in range(200):
        s = robot.step(s, IDEAL, 4.0, 8.0, dt, rng)
        assert math.hypot(s.x, s.y - radius) == pytest.approx(radius, rel=1e-9)  # on the circle each step
    assert (s.x, s.y) == pytest.approx((0.0, 0.0), abs=1e-9)
    assert s.theta == pytest.approx(0.0, abs=1e-9)


def test_true_errors_curve_the_path():
    w = robot.world(RobotConfig(), PRESETS["default"])._replace(slip_sigma=0.0)
    s = drive(State(), w, 5.0, 5.0, 2.0)
    assert s.theta < 0.0 and s.y < 0.0  # left wheel larger: veers right


def test_deadband():
    w = IDEAL._replace(deadband=0.5)
    assert drive(State(), w, 0.49, -0.49, 1.0).x == 0.0
    s = drive(State(), w, 0.5, 0.5, 1.0)
    assert s.x == pytest.approx(R * 0.5)


def test_saturation():
    s = drive(State(), IDEAL, 25.0, -25.0, 0.1)
    assert (s.speed_left, s.speed_right) == (10.0, -10.0)
    assert robot.motor_target(-7.0, IDEAL) == -7.0


def test_lag_time_constant():
    w = IDEAL._replace(motor_lag=0.05)
    s = drive(State(), w, 10.0, 10.0, 0.05)
    assert s.speed_left == pytest.approx(10.0 * (1 - math.exp(-1)))
    # The angle turned is the exact integral of the speed: 10*(t - tau*(1 - e^-t/tau)).
    assert s.angle_left == pytest.approx(10.0 * (0.05 - 0.05 * (1 - math.exp(-1))))
    s = drive(s, w, 10.0, 10.0, 0.5)
    assert s.speed_left == pytest.approx(10.0, rel=1e-4)
    stopped = drive(s, w, 0.0, 0.0, 0.05)
    assert stopped.speed_left == pytest.approx(10.0 * math.exp(-1), rel=1e-4)
    assert stopped.accel < 0.0


def test_forward_acceleration_of_the_motors():
    w = IDEAL._replace(motor_lag=0.1)
    s = robot.step(State(), w, 10.0, 10.0, DT, np.random.default_rng(1))
    assert s.accel == pytest.approx(R * 10.0 * (1 - math.exp(-DT / 0.1)) / DT)


def test_slip_statistics():
    w = IDEAL._replace(slip_sigma=0.05)
    rng = np.random.default_rng(3)
    steady = State(speed_left=5.0, speed_right=5.0)
    ratios = []
    for _ in range(4000):
        s = robot.step(steady, w, 5.0, 5.0, DT, rng)
        ratios.append(s.v / (R * 5.0))  # (slip_l + slip_r) / 2
        assert s.angle_left == pytest.approx(5.0 * DT)  # the encoders never see slip
    ratios = np.array(ratios)
    assert ratios.mean() == pytest.approx(1.0, abs=0.005)
    assert ratios.std() == pytest.approx(0.05 / math.sqrt(2), rel=0.1)


def test_same_seed_same_path():
    w = robot.world(RobotConfig(), PRESETS["harsh"])
    a, b, c = (drive(State(), w, 6.0, 4.0, 1.0, seed) for seed in (5, 5, 6))
    assert a == b and a != c


def test_teleport_keeps_unset_and_stops_the_wheels():
    s = drive(State(), IDEAL, 5.0, 5.0, 0.5)
    t = robot.teleport(s, y=2.0, theta=7.0)
    assert (t.x, t.y, t.theta) == (s.x, 2.0, pytest.approx(7.0 - 2 * math.pi))
    assert (t.speed_left, t.speed_right, t.v, t.omega) == (0.0, 0.0, 0.0, 0.0)
    assert (t.angle_left, t.angle_right) == (s.angle_left, s.angle_right)
