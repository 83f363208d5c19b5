"""WPILib's DifferentialDrivePoseEstimator beside zenav's localizer on one stream (bench/peers.py)."""

from __future__ import annotations

import dataclasses
import math
import subprocess
import sys

import msgspec
import pytest

from zenav.bench import peers
from zenav.bench.studies.localizer import drive_square
from zenav.common import extras
from zenav.common import messages as m
from zenav.common.config import RobotConfig
from zenav.common.scenarios import scenario

SECONDS = 12.0  # [s] of the square: past the warm-up and round a corner


def test_wheel_travel_unwraps_the_counts_at_the_nominal_radius():
    robot = RobotConfig(ticks_per_rev=360)
    per_tick = 2.0 * math.pi * robot.wheel_radius / 360
    top = 2**31 - 1
    enc = [m.Encoders(t=0.0, left=top - 1, right=0), m.Encoders(t=0.01, left=-(2**31) + 1, right=-3)]
    (_, l0, r0), (t, left, right) = peers.wheel_travel(enc, robot)
    assert (l0, r0, t) == (0.0, 0.0, 0.01)
    assert left == pytest.approx(3 * per_tick) and right == pytest.approx(-3 * per_tick)


needs_wpimath = pytest.mark.skipif(not extras.installed("wpimath"), reason="robotpy-wpimath is not installed: pip install 'zenav[peers]'")


@pytest.fixture(scope="module")
def square():
    sc = scenario("default")
    return drive_square(sc, 1, SECONDS), RobotConfig(ticks_per_rev=sc.ticks_per_rev)


@needs_wpimath
def test_both_estimators_are_scored_on_the_same_stream_and_the_best_tuning_is_no_worse(square):
    streams, robot = square
    c = peers.compare(streams, robot, sweep=peers.short_sweep())
    assert c.zenav.n > 0 and c.default.n == c.best.n > 0
    assert c.best.rmse <= c.default.rmse < 0.1  # WPILib follows the square within centimetres
    assert c.tuning in (peers.DEFAULT, *peers.short_sweep())
    assert c.ratio == pytest.approx(c.best.rmse / c.zenav.rmse)
    assert peers.lines({"default": [c]})[2].startswith("| default | ")


@needs_wpimath
def test_wpilib_uses_the_fixes_and_a_team_gate_drops_a_far_one(square):
    streams, robot = square
    with_fixes = peers.run_wpilib(streams, robot, peers.DEFAULT)
    blind = peers.run_wpilib(dataclasses.replace(streams, fixes=[]), robot, peers.DEFAULT)
    assert with_fixes.rmse < blind.rmse  # the gyro's bias and the wheels' errors drift it without the camera
    # Every fix displaced 1 m: taken as they come, they pull WPILib off; behind a 0.25 m gate, none is used.
    far = [(t, msgspec.structs.replace(f, x=f.x + 1.0)) for t, f in streams.fixes]
    gated = peers.Tuning(peers.DEFAULT.state, peers.DEFAULT.vision, gate=0.25)
    shifted = dataclasses.replace(streams, fixes=far)
    assert peers.run_wpilib(shifted, robot, gated).rmse == pytest.approx(blind.rmse)
    assert peers.run_wpilib(shifted, robot, peers.DEFAULT).rmse > 2.0 * blind.rmse


def test_the_bench_section_without_the_extra_says_which_to_install(tmp_path):
    argv = ["bench", "--only", "peers", "--out", str(tmp_path / "report")]
    code = f"import sys; sys.modules['wpimath'] = None; from zenav.cli.main import main; sys.exit(main({argv!r}))"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and "robotpy-wpimath: pip install 'zenav[peers]'" in done.stderr
    assert "Traceback" not in done.stderr and not (tmp_path / "report").exists()
