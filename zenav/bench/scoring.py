"""Scores of shared/spec/scenarios.md: an estimate's error against the truth at its own t.

One `Score` for every run the bench and the studies measure, live or offline: the
localization error after the warm-up (RMSE, max, final, heading RMSE), and for runs
that feed a localizer, what became of the camera's fixes.
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from zenav.common.track import Sample, Track

WARMUP = 2.0  # [s] after the first estimate before errors count (the localizer's first fixes)


@dataclass(frozen=True)
class Score:
    """Errors of one run after the warm-up: position [m], heading [rad]."""

    rmse: float
    max: float
    final: float
    heading_rmse: float
    n: int  # estimates scored
    outage_end: float | None = None  # [m] error just before the first fix used after a VPS outage
    fixes_accepted: int | None = None
    fixes_rejected: int | None = None
    outliers_accepted: int | None = None  # accepted fixes further than the outlier distance from the truth


def rms(values: Iterable[float]) -> float:
    """Root mean square (nan for none)."""
    a = np.fromiter(values, dtype=float)
    return float(np.sqrt(np.mean(a * a))) if a.size else math.nan


def score(est: Sequence[Sample], truth: Track | Sequence[Sample], warmup: float = WARMUP) -> Score:
    """The error of an estimate's series against the truth at its t, from `warmup` after its first sample."""
    track = truth if isinstance(truth, Track) else Track(truth)
    t, pos, th = track.errors(est)
    keep = t >= (t[0] if len(t) else 0.0) + warmup
    pos, th = pos[keep], th[keep]
    if not len(pos):
        return Score(math.nan, math.nan, math.nan, math.nan, 0)
    return Score(rms(pos), float(pos.max()), float(pos[-1]), rms(th), len(pos))


def summary(values: Sequence[float]) -> tuple[float, float, float]:
    """(mean, sample standard deviation, max) of finite values (nan where none)."""
    finite = [v for v in values if math.isfinite(v)]
    if not finite:
        return math.nan, math.nan, math.nan
    return statistics.fmean(finite), statistics.stdev(finite) if len(finite) > 1 else 0.0, max(finite)
