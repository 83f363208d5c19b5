"""The stepped robot: wheel and body commands, sensors, seeding; and the fault schedule."""

import math

import pytest

from zenav.common.config import RobotConfig
from zenav.common.scenarios import PRESETS, Fault, Scenario, scenario
from zenav.world import faults, sensors
from zenav.world.sim import SimRobot

DEFAULT = PRESETS["default"]
IDEAL = Scenario(
    wheel_radius_err_left=0.0, wheel_radius_err_right=0.0, track_width_err=0.0, slip_sigma=0.0, motor_lag=0.0, motor_deadband=0.0
)


def test_drive_goes_through_the_nominal_geometry():
    bot = SimRobot(RobotConfig(), IDEAL, seed=1)
    for _ in range(100):
        s = bot.drive(0.2, 0.0, 0.01)
    assert (s.x, s.y, s.v) == pytest.approx((0.2, 0.0, 0.2))
    bot = SimRobot(RobotConfig(), IDEAL, seed=1, x=1.0, theta=math.pi / 2)
    for _ in range(50):
        s = bot.drive(0.0, 1.0, 0.01)
    assert (s.x, s.y, s.theta, s.omega) == pytest.approx((1.0, 0.0, math.pi / 2 + 0.5, 1.0))


def test_wheel_commands_saturate_keeping_the_curvature():
    bot = SimRobot(RobotConfig(max_wheel_speed=5.0), IDEAL, seed=1)
    left, right = bot.wheels(1.0, 2.0)
    assert max(abs(left), abs(right)) == pytest.approx(5.0)
    assert (right - left) / (right + left) == pytest.approx(2.0 * 0.1156 / 2 / 1.0)
    assert bot.wheels(0.0, 0.0) == (0.0, 0.0)


def test_deadband_of_the_true_motors_stops_slow_commands():
    bot = SimRobot(RobotConfig(ticks_per_rev=360), DEFAULT, seed=1)
    bot.drive(0.01, 0.0, 0.01)  # 0.3 rad/s at the wheels: inside the deadband
    assert (bot.state.x, bot.state.speed_left, bot.encoders()) == (0.0, 0.0, (0, 0))


def test_sensors_read_the_state():
    bot = SimRobot(RobotConfig(), DEFAULT, seed=1, encoder_start=2**31 - 1)
    for _ in range(10):
        bot.step(5.0, 5.0, 0.01)
    left, right = bot.encoders()
    assert left < 0 and right < 0  # wrapped past 2^31 - 1
    gyro, _, _ = bot.imu()
    assert abs(gyro) < 0.1
    assert abs(bot.compass() - bot.state.theta) < math.radians(15.0)


def test_seeded_and_reading_sensors_leaves_the_path_alone():
    a, b, c = (SimRobot(RobotConfig(), PRESETS["harsh"], seed) for seed in (5, 5, 6))
    for _ in range(100):
        a.step(6.0, 4.0, 0.01)
        b.step(6.0, 4.0, 0.01)
        c.step(6.0, 4.0, 0.01)
        b.imu(), b.compass()
    assert a.state == b.state and a.state != c.state
    a.reseed(9)
    b.reseed(9)
    assert a.imu() == b.imu() and a.compass() == b.compass()


def test_teleport_keeps_the_encoders():
    bot = SimRobot(RobotConfig(), DEFAULT, seed=1)
    for _ in range(30):
        bot.step(6.0, 6.0, 0.01)
    ticks = bot.encoders()
    s = bot.teleport(x=2.0, theta=1.0)
    assert (s.x, s.theta, s.v) == (2.0, 1.0, 0.0) and bot.encoders() == ticks


def test_compass_schedule_on_the_sensor_grid():
    assert [k for k in range(1, 31) if sensors.due(k, 10.0, 100.0)] == [10, 20, 30]
    assert [k for k in range(1, 26) if sensors.due(k, 4.0, 50.0)] == [13, 25]
    assert sensors.due(0, 10.0, 100.0)


def test_fault_effects_while_scheduled():
    sc = Scenario(
        faults=(
            Fault(kind="gyro_dead", start=1.0, duration=1.0),
            Fault(kind="duplicate", start=1.5, duration=1.0),
            Fault(kind="future_stamp", start=3.0, duration=0.5),
            Fault(kind="encoder_frozen", start=4.0, duration=1.0),
        )
    )
    assert faults.at(sc, 0.5) == faults.Effect(stamp=0.5, copies=1, imu=True, freeze_left=False)
    assert faults.at(sc, 1.7) == faults.Effect(stamp=1.7, copies=2, imu=False, freeze_left=False)
    assert faults.at(sc, 2.0).imu and faults.at(sc, 2.0).copies == 2  # gyro_dead ends at start + duration
    assert faults.at(sc, 3.2).stamp == pytest.approx(3.2 + faults.FUTURE_OFFSET)
    hold = faults.EncoderHold()
    counts = [hold.apply(faults.at(sc, t), n) for t, n in ((3.9, 10), (4.0, 11), (4.5, 15), (5.0, 20))]
    assert counts == [10, 11, 11, 20]  # held from the fault's first sample, released after it


def test_vps_outage_window():
    sc = scenario("harsh")
    assert [faults.vps_outage(sc, t) for t in (19.9, 20.0, 29.9, 30.0)] == [False, True, True, False]
    assert not faults.vps_outage(DEFAULT, 20.0)
    assert faults.vps_outage_window(sc) == (20.0, 30.0) and faults.vps_outage_window(DEFAULT) is None
