"""Scoring a recorded run: localization error after the warm-up, goal errors against the truth."""

from __future__ import annotations

import math

import pytest

from zenav.bench.scoring import score
from zenav.bench.trials import Recorder, Trial, TrialGoal
from zenav.common import messages as m


class FakeClient:
    def __init__(self) -> None:
        self.callbacks = {}

    def subscribe(self, suffix, callback, typ=None) -> None:
        self.callbacks[suffix] = callback


def recorder_driving_east(speed: float = 0.1, seconds: float = 10.0) -> tuple[FakeClient, Recorder]:
    """Truth moving along x at `speed` [m/s], turning at 0.1 rad/s, sampled at 100 Hz."""
    client = FakeClient()
    rec = Recorder(client)
    for k in range(int(seconds * 100) + 1):
        t = k / 100
        client.callbacks["sim/truth"](m.Truth(t=t, x=speed * t, y=0.0, theta=0.1 * t, v=speed, omega=0.1))
    return client, rec


def test_score_skips_the_warm_up_and_measures_the_rest():
    _, rec = recorder_driving_east()
    truth = rec.series("sim/truth")
    # an estimate 5 cm off in y and 1 deg off in heading, after 20 cm off during the first second
    est = [(t, x, y + (0.2 if t < 1.0 else 0.05), th + math.radians(1)) for t, x, y, th in truth[::10]]
    s = score(est, truth, warmup=2.0)
    assert s.rmse == pytest.approx(0.05) and s.max == pytest.approx(0.05) and s.final == pytest.approx(0.05)
    assert s.heading_rmse == pytest.approx(math.radians(1))
    assert s.n == len([e for e in est if e[0] >= 2.0])


def test_goal_errors_use_the_truth_when_the_goal_ended():
    client, rec = recorder_driving_east()
    trial = Trial(
        rec,
        [
            TrialGoal("point", (0.5, 0.0), "succeeded", 0.0, 5.0),
            TrialGoal("point", (9.0, 9.0), "aborted", 5.0, 6.0, "no progress"),
            TrialGoal("turn", (0.5,), "succeeded", 6.0, 7.55),
            TrialGoal("path", (1.0, 0.0), "succeeded", 0.0, 9.0),
        ],
    )
    assert trial.errors("point") == [pytest.approx(0.0, abs=1e-9)]
    assert trial.errors("turn") == [pytest.approx(0.255)]
    assert trial.errors("path") == [pytest.approx(0.1)]
    assert trial.durations("point") == [5.0] and trial.durations("turn") == [pytest.approx(1.55)]


def test_fixes_carry_the_time_the_localizer_received_them():
    client, rec = recorder_driving_east(seconds=1.0)
    fix = m.VpsPose(t=0.5, x=0.05, y=0.0, theta=0.05)
    client.callbacks["vps/pose"](fix)
    client.callbacks["vps/pose"](m.VpsPose(t=0.6, x=0.06, y=0.0, theta=0.06))  # never reached the localizer
    client.callbacks["localizer/fixes"](
        m.Fix(
            t=0.5,
            t_arrival=0.81,
            latency=0.31,
            replay_depth=31,
            innovation=(0.0, 0.0, 0.0),
            mahalanobis_d2=0.1,
            accepted=True,
            reason="accepted",
        )
    )
    assert rec.fixes() == [(0.81, fix)]
