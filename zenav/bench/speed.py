"""How fast the simulation may run: the same trials at several realtime factors, compared
with realtime goal by goal.

The trial is the path trial then the turn sweep: turns at 2 rad/s are where a late
command shows first. Per goal: the truth heading error of each turn, the duration,
and the fused pose's RMSE over it. A realtime factor is within noise of realtime
when every goal succeeded, the sim never fell behind, and each of the three means
differs from realtime's by less than twice the standard error of the difference.
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from zenav.bench.accuracy import Spec, Summary

METRICS = ("turn error [deg]", "goal time [s]", "pose RMSE [cm]")


def per_goal(s: Summary) -> dict[str, list[float]]:
    """The three metrics of every succeeded goal of a run."""
    return {
        "turn error [deg]": [math.degrees(e) for e in s.errors["turn"]],
        "goal time [s]": [d for ds in s.durations.values() for d in ds],
        "pose RMSE [cm]": [e * 100 for e in s.goal_rmse],
    }


def differs(a: Sequence[float], b: Sequence[float]) -> bool:
    """Whether the means of two samples differ by more than twice the standard error of the difference."""
    if len(a) < 2 or len(b) < 2:
        return True
    se = math.sqrt(statistics.variance(a) / len(a) + statistics.variance(b) / len(b))
    return abs(statistics.fmean(a) - statistics.fmean(b)) > 2.0 * se


@dataclass(frozen=True)
class Row:
    """One realtime factor: its runs' pooled metrics and the verdict."""

    harness: str  # processes or in-process
    rtf: float
    goals: int
    failed: int
    overruns: int
    wall: float  # [s] driving time of all its runs
    means: dict[str, float]
    differs: tuple[str, ...]  # metrics whose mean differs from realtime's beyond noise
    within_noise: bool
    failures: list[str]  # goals that did not succeed: seed, result, why


def study(harness: str, rtfs: Sequence[float], seeds: Sequence[int], run: Callable[[Spec, float], Summary]) -> list[Row]:
    """Run the trial on a harness at every rtf (the first is the reference, 1.0) for every seed."""
    pooled: dict[float, dict[str, list[float]]] = {}
    rows = []
    for rtf in rtfs:
        try:
            runs = [run(Spec(seed=s, trial="path", harness=harness), rtf) for s in seeds]
        except TimeoutError as e:  # the stack never became ready at this factor: it and every higher one fail
            why = f"rtf {rtf:g}: {e}"
            nan = {k: math.nan for k in METRICS}
            rows.append(Row(harness, rtf, 0, len(seeds), 0, 0.0, means=nan, differs=(), within_noise=False, failures=[why]))
            break
        pool: dict[str, list[float]] = {k: [] for k in METRICS}
        for r in runs:
            for k, v in per_goal(r).items():
                pool[k] += v
        pooled[rtf] = pool
        ref = pooled[rtfs[0]]
        off = tuple(k for k in METRICS if rtf != rtfs[0] and differs(ref[k], pool[k]))
        failed = sum(len(r.failures) for r in runs)
        overruns = sum(r.overruns for r in runs)
        rows.append(
            Row(
                harness=harness,
                rtf=rtf,
                goals=sum(r.goals for r in runs),
                failed=failed,
                overruns=overruns,
                wall=sum(r.wall for r in runs),
                means={k: statistics.fmean(v) if v else math.nan for k, v in pool.items()},
                differs=off,
                within_noise=not off and failed == 0 and overruns == 0,
                failures=[f"seed {r.spec.seed}: {f}" for r in runs for f in r.failures],
            )
        )
    return rows


def highest(rows: Sequence[Row]) -> float:
    """The highest rtf such that it and every lower one tested is within noise of realtime."""
    best = rows[0].rtf
    for row in rows:
        if not row.within_noise:
            break
        best = row.rtf
    return best


def highest_by_harness(rows: Sequence[Row]) -> dict[str, float]:
    """The highest rtf within noise, per harness studied."""
    return {h: highest([r for r in rows if r.harness == h]) for h in dict.fromkeys(r.harness for r in rows)}
