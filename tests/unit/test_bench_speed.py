"""The speed study's verdicts: within noise of realtime, or not, and the highest factor."""
from __future__ import annotations

import math

import numpy as np

from zenav.tools import bench_speed
from zenav.tools.bench_accuracy import Spec, Summary
from zenav.tools.bench_trials import Score


def summary(spec: Spec, rtf: float, turn_deg: list[float], failures: tuple[str, ...] = (), overruns: int = 0) -> Summary:
    n = len(turn_deg)
    return Summary(
        spec=spec, rtf=rtf, pose=Score(0.01, 0.02, 0.01, 0.01, 100), odom=Score(0.02, 0.03, 0.02, 0.02, 100),
        errors={"point": [], "path": [0.005], "turn": [math.radians(d) for d in turn_deg]},
        durations={"point": [], "path": [12.0], "turn": [1.0 + 0.01 * i for i in range(n)]},
        goal_rmse=[0.005 + 0.0001 * i for i in range(n + 1)], goals=n + 1 + len(failures), failures=list(failures),
        overruns=overruns, wall=10.0 / rtf,
    )


def test_differs_only_beyond_twice_the_standard_error():
    rng = np.random.default_rng(3)
    a = list(rng.normal(1.0, 0.2, 30))
    assert not bench_speed.differs(a, list(rng.normal(1.0, 0.2, 30)))
    assert bench_speed.differs(a, list(rng.normal(2.0, 0.2, 30)))
    assert bench_speed.differs(a, [1.0])  # too few samples to tell: not within noise


def test_study_pools_seeds_and_stops_at_the_first_bad_factor():
    turns = {1.0: [1.0, 1.2, 0.8, 1.1, 0.9, 1.0], 2.0: [1.1, 0.9, 1.0, 1.2, 0.8, 1.0], 4.0: [6.0, 7.0, 6.5, 5.5, 6.2, 6.8]}
    asked = []

    def run(spec: Spec, rtf: float) -> Summary:
        asked.append((spec.seed, spec.trial, spec.harness, rtf))
        failures = ("aborted: pose stale",) if rtf == 8.0 else ()
        return summary(spec, rtf, turns.get(rtf, turns[1.0]), failures)

    rows = bench_speed.study("in-process", (1.0, 2.0, 4.0, 8.0), (1, 2), run)
    assert asked[:2] == [(1, "path", "in-process", 1.0), (2, "path", "in-process", 1.0)] and len(asked) == 8
    verdict = {r.rtf: r.within_noise for r in rows}
    assert verdict == {1.0: True, 2.0: True, 4.0: False, 8.0: False}
    assert rows[2].differs == ("turn error [deg]",)
    assert rows[3].failures == ["seed 1: aborted: pose stale", "seed 2: aborted: pose stale"]
    assert bench_speed.highest(rows) == 2.0
    assert bench_speed.highest_by_harness(rows) == {"in-process": 2.0}


def test_an_overrun_is_never_within_noise():
    def run(spec, rtf):
        return summary(spec, rtf, [1.0, 1.1, 0.9], overruns=int(rtf > 1))

    assert [r.within_noise for r in bench_speed.study("processes", (1.0, 3.0), (1,), run)] == [True, False]
