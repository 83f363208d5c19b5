"""The navigator study: its goal machine on the world model's robot with the default scenario's errors."""

import math
import statistics

import pytest

from zenav.bench.studies import navigator as study
from zenav.bench.studies.harness import Trial
from zenav.common.config import RobotConfig
from zenav.common.scenarios import PRESETS
from zenav.services.navigator.params import CONTROLLERS, Params

DEFAULT = PRESETS["default"]


def test_trial_robot_lag_deadband_and_encoders():
    trial = Trial(RobotConfig(ticks_per_rev=360), DEFAULT, seed=1, camera=False)
    trial.step(*trial.bot.wheels(0.01, 0.0))  # 0.3 rad/s at the wheels: inside the deadband
    s = trial.bot.state
    assert (s.x, s.speed_left, s.speed_right) == (0.0, 0.0, 0.0)
    for _ in range(100):
        trial.step(*trial.bot.wheels(0.2, 0.0))
    assert trial.bot.state.x == pytest.approx(0.2 - 0.2 * 0.05, abs=0.01)  # a second at 0.2 m/s less the lag
    assert trial.odom is not None and trial.odom.v == pytest.approx(0.2, abs=0.06)  # one tick per sample is 0.059 m/s


@pytest.mark.parametrize("name", CONTROLLERS)
def test_path_trial_with_the_true_pose(name):
    for seed in range(3):
        out = study.path_trial(Params(controller=name), DEFAULT, seed)
        assert out.result == "succeeded" and math.dist((out.x, out.y), (1.0, 1.0)) < 0.005 and out.duration < 20.0


def test_default_controller_meets_the_targets_with_a_localizer_like_pose_error():
    errors = [math.dist((o.x, o.y), (1.0, 1.0)) for o in (study.path_trial(Params(), DEFAULT, s, 0.005) for s in range(10))]
    assert statistics.fmean(errors) <= 0.015 and max(errors) <= 0.03


def test_square_returns_to_the_start():
    outs = study.square_trial(Params(), DEFAULT, seed=3, laps=1)
    assert [o.result for o in outs] == ["succeeded"] * 4
    assert math.hypot(outs[-1].x, outs[-1].y) < 0.005


def test_turn_sweep_has_no_overshoot_beyond_tolerance():
    p = Params()
    for out, deg in zip(study.turn_sweep(p, DEFAULT, 0, (10.0, 90.0, -170.0)), (10.0, 90.0, -170.0)):
        assert out.result == "succeeded" and out.overshoot <= p.heading_tolerance
        assert abs(math.remainder(out.theta - math.radians(deg), 2 * math.pi)) <= p.heading_tolerance


def test_report_has_a_row_per_controller_and_condition():
    text = study.report(seeds=1)
    rows = [line for line in text.splitlines() if line.startswith("| ") and "controller" not in line and "target" not in line]
    assert len(rows) == len(CONTROLLERS) * len(study.CONDITIONS) + len(study.HEADINGS)
