"""The speed study's verdicts: within noise of realtime, or not, and the highest factor."""

from __future__ import annotations

import numpy as np

from tests.support.bench import summary
from zenav.bench import speed
from zenav.bench.accuracy import Spec, Summary


def test_differs_only_beyond_twice_the_standard_error():
    rng = np.random.default_rng(3)
    a = list(rng.normal(1.0, 0.2, 30))
    assert not speed.differs(a, list(rng.normal(1.0, 0.2, 30)))
    assert speed.differs(a, list(rng.normal(2.0, 0.2, 30)))
    assert speed.differs(a, [1.0])  # too few samples to tell: not within noise


def test_study_pools_seeds_and_stops_at_the_first_bad_factor():
    turns = {1.0: [1.0, 1.2, 0.8, 1.1, 0.9, 1.0], 2.0: [1.1, 0.9, 1.0, 1.2, 0.8, 1.0], 4.0: [6.0, 7.0, 6.5, 5.5, 6.2, 6.8]}
    asked = []

    def run(spec: Spec, rtf: float) -> Summary:
        asked.append((spec.seed, spec.trial, spec.harness, rtf))
        failures = ("aborted: pose stale",) if rtf == 8.0 else ()
        return summary(spec, rtf, turns.get(rtf, turns[1.0]), failures)

    rows = speed.study("in-process", (1.0, 2.0, 4.0, 8.0), (1, 2), run)
    assert asked[:2] == [(1, "path", "in-process", 1.0), (2, "path", "in-process", 1.0)] and len(asked) == 8
    verdict = {r.rtf: r.within_noise for r in rows}
    assert verdict == {1.0: True, 2.0: True, 4.0: False, 8.0: False}
    assert rows[2].differs == ("turn error [deg]",)
    assert rows[3].failures == ["seed 1: aborted: pose stale", "seed 2: aborted: pose stale"]
    assert speed.highest(rows) == 2.0
    assert speed.highest_by_harness(rows) == {"in-process": 2.0}


def test_an_overrun_is_never_within_noise():
    def run(spec, rtf):
        return summary(spec, rtf, [1.0, 1.1, 0.9], overruns=int(rtf > 1))

    assert [r.within_noise for r in speed.study("processes", (1.0, 3.0), (1,), run)] == [True, False]


def test_a_stack_never_ready_fails_its_factor_and_ends_the_study():
    def run(spec, rtf):
        if rtf >= 4.0:
            raise TimeoutError("navigator not ready after 60.0 s")
        return summary(spec, rtf, [1.0, 1.1, 0.9])

    rows = speed.study("in-process", (1.0, 2.0, 4.0, 8.0), (1, 2), run)
    assert [(r.rtf, r.within_noise) for r in rows] == [(1.0, True), (2.0, True), (4.0, False)]
    assert rows[2].failed == 2 and "not ready" in rows[2].failures[0]
    assert speed.highest(rows) == 2.0
