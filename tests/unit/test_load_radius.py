"""The load-dependent wheel radius: payload schedule and load transfer in the world model."""

from __future__ import annotations

import numpy as np
import pytest

from zenav.common.config import RobotConfig
from zenav.common.scenarios import PRESETS, scenario
from zenav.world import robot
from zenav.world.robot import Load, State, World

R, TRACK, DT = 0.03365, 0.1156, 0.01
LOAD = Load(schedule=((1.0, 0.5), (2.0, -0.25)), per_kg=-0.004, per_accel=-0.002, per_lateral=-0.003)
LOADED = World(radius_left=R, radius_right=R, track=TRACK, motor_lag=0.0, deadband=0.0, motor_max=10.0, slip_sigma=0.0, load=LOAD)


def test_payload_is_the_newest_step_started():
    sched = LOAD.schedule
    assert [robot.payload(sched, t) for t in (0.0, 0.99, 1.0, 1.5, 2.0, 9.0)] == [0.0, 0.0, 0.5, 0.5, -0.25, -0.25]
    assert robot.payload((), 5.0) == 0.0


def test_radius_shrinks_with_payload():
    assert robot.radii(State(t=0.5), LOADED) == (R, R)
    left, right = robot.radii(State(t=1.5), LOADED)
    assert left == right == pytest.approx(R * (1.0 - 0.004 * 0.5))
    assert robot.radii(State(t=2.5), LOADED)[0] == pytest.approx(R * (1.0 + 0.004 * 0.25))


def test_load_transfer_compresses_under_acceleration_and_the_outer_wheel_in_a_turn():
    left, right = robot.radii(State(accel=1.0), LOADED)
    assert left == right == pytest.approx(R * (1.0 - 0.002))
    left, right = robot.radii(State(v=0.3, omega=2.0), LOADED)  # turning left: the right wheel is outer
    assert right == pytest.approx(R * (1.0 - 0.003 * 0.6)) and left == pytest.approx(R * (1.0 + 0.003 * 0.6))


def test_the_ground_moves_by_the_loaded_radius_and_time_advances():
    rng = np.random.default_rng(1)
    s = State(t=1.0)
    s = robot.step(s, LOADED, 5.0, 5.0, DT, rng)  # no lag: 5 rad/s at once, so the step is straight
    assert s.t == pytest.approx(1.0 + DT)
    assert s.x == pytest.approx(5.0 * DT * R * (1.0 - 0.004 * 0.5))
    assert robot.teleport(s, x=0.0).t == s.t  # putting the robot down keeps its clock


def test_no_load_model_is_the_constant_radius():
    w = robot.world(RobotConfig(), PRESETS["default"])
    assert w.load == robot.NO_LOAD
    assert robot.radii(State(t=30.0, accel=2.0, v=0.3, omega=1.0), w) == (w.radius_left, w.radius_right)


def test_harsh_varies_around_its_mean_radius():
    sc = PRESETS["harsh"]
    w = robot.world(RobotConfig(), sc)
    assert w.radius_left == pytest.approx(0.0673 / 2 * (1 + 0.01 - 0.005))  # the mean: load_radius_err
    assert w.load.per_kg < 0.0 and w.load.per_accel < 0.0 and w.load.per_lateral < 0.0
    # The payload schedule averages to the nominal load over the reference trials' 60 s.
    edges = [t for t, _ in sc.load_payload] + [60.0]
    mean = sum(kg * (b - a) for (a, kg), b in zip(sc.load_payload, edges[1:])) / 60.0
    assert mean == pytest.approx(0.0)
    assert scenario("default", {"load_payload": [[5.0, 1.0]]}).load_payload == ((5.0, 1.0),)
