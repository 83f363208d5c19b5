"""`zenav calibrate` on the simulated robot (sim + motor + vps on a real router): the fit finds its true track width."""

from __future__ import annotations

import argparse
import math

import pytest

from zenav.cli import calibrate
from zenav.common.config import Settings
from zenav.services.driver import umbmark as u

RTF = 2.0
SIDE = 0.5  # [m]
TRACK_ERR = 0.05  # the true track is 5 % wider than the nominal one
WORLD = dict(  # no noise: the squares show only the geometry, the VPS sees the truth
    wheel_radius_err_left=0.0,
    wheel_radius_err_right=0.0,
    track_width_err=TRACK_ERR,
    slip_sigma=0.0,
    motor_deadband=0.0,
    ticks_per_rev=100_000,
    vps_noise_xy=0.0,
    vps_noise_theta_deg=0.0,
    vps_drop=0.0,
    vps_outlier=0.0,
)


def test_calibrate_squares_on_the_sim_recover_the_track_width(make_stack, client, monkeypatch):
    stack = make_stack(["sim", "motor", "vps"], sim={"rtf": RTF, "x0": 1.0, "y0": 1.0}, scenario=WORLD)
    client.wait_alive(["sim", "motor", "vps"], timeout=20.0)
    starts = iter([(1.0, 1.0, 0.3), (1.2, 0.8, -0.5)])  # where "the user" puts the robot for each run

    def place(prompt: str) -> str:
        x, y, theta = next(starts)
        client.query("sim/reset", {"x": x, "y": y, "theta": theta})
        return ""

    monkeypatch.setattr("builtins.input", place)
    robot = stack.settings.robot
    nominal = u.Geometry(robot.track_width, robot.wheel_radius, robot.wheel_radius)
    args = argparse.Namespace(side=SIDE, runs=1, speed=0.15, measure="vps")
    runs = calibrate.drive_runs(client, args, robot, nominal)
    assert [r.clockwise for r in runs] == [True, False]
    assert math.hypot(*runs[0].error) > 0.02  # a 5 % track error shows
    fit = u.fit(runs, nominal)
    assert math.isclose(fit.geometry.track, robot.track_width * (1.0 + TRACK_ERR), rel_tol=0.001), fit
    assert math.isclose(fit.ratio, 1.0, abs_tol=0.001), fit


def test_calibrate_without_anyone_at_the_keyboard_says_so(client, monkeypatch):
    def closed(prompt: str) -> str:
        raise EOFError

    monkeypatch.setattr("builtins.input", closed)
    robot = Settings.load(None).robot
    args = argparse.Namespace(side=SIDE, runs=1, speed=0.15, measure="vps")
    with pytest.raises(RuntimeError, match="stdin is closed: calibrate waits for Enter before each square"):
        calibrate.drive_runs(client, args, robot, u.Geometry(robot.track_width, robot.wheel_radius, robot.wheel_radius))
