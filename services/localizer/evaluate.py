"""Scoring a localizer mode on recorded streams (shared/spec/scenarios.md, "Scores").

Given the odometry, the fixes with their arrival times and the truth of one run,
`evaluate` feeds a mode in arrival order and compares every pose with the truth
interpolated at its t. Pure: the benchmark and the tests call it on any streams.
"""
from __future__ import annotations

import bisect
import heapq
import math
from dataclasses import dataclass
from typing import Optional, Sequence

from zenav.common import messages as m
from zenav.common.geometry import wrap_angle

from .base import Mode


@dataclass(frozen=True)
class Score:
    """Errors of one run after the warm-up: position [m], heading [rad]."""

    rmse: float
    max: float
    final: float
    heading_rmse: float
    outage_end: Optional[float]  # position error just before the first fix after the outage is used
    fixes_accepted: int
    fixes_rejected: int
    outliers_accepted: int  # accepted fixes further than `outlier_dist` from the truth


def _truth_at(truth: Sequence[m.Truth], times: list[float], t: float) -> tuple[float, float, float]:
    """Truth (x, y, theta) interpolated at t."""
    i = min(max(bisect.bisect_left(times, t), 1), len(truth) - 1)
    a, b = truth[i - 1], truth[i]
    f = min(max((t - a.t) / (b.t - a.t), 0.0), 1.0) if b.t > a.t else 1.0
    return a.x + f * (b.x - a.x), a.y + f * (b.y - a.y), wrap_angle(a.theta + f * wrap_angle(b.theta - a.theta))


def evaluate(
    loc: Mode,
    odom: Sequence[m.Odom],
    fixes: Sequence[tuple[float, m.VpsPose]],
    truth: Sequence[m.Truth],
    imu: Sequence[m.Imu] = (),
    compass: Sequence[m.Compass] = (),
    warmup: float = 2.0,
    outage: Optional[tuple[float, float]] = None,
    outlier_dist: float = 0.25,
) -> Score:
    """Run `loc` on the streams; `fixes` are (arrival time, fix); `outage` is (start, end) [s].

    At equal times fixes come first, then the IMU and the compass, then odometry
    (the sensors' samples reach the localizer before odometry computed from them).
    """
    times = [s.t for s in truth]
    events = heapq.merge(
        ((t, 0, "fix", f) for t, f in sorted(fixes, key=lambda f: f[0])),
        ((s.t, 1, "imu", s) for s in imu),
        ((s.t, 2, "compass", s) for s in compass),
        ((s.t, 3, "odom", s) for s in odom),
        key=lambda e: (e[0], e[1]),
    )
    t0 = odom[0].t if odom else 0.0
    errors, heading_sq = [], 0.0
    outage_end = None
    accepted = rejected = bad = 0
    last_err = math.nan
    for t, _, kind, msg in events:
        if kind == "fix":
            rec = loc.on_fix(msg, t)
            if outage is not None and outage_end is None and msg.t >= outage[1] and rec.accepted:
                outage_end = last_err
            if rec.accepted:
                accepted += 1
                tx, ty, _ = _truth_at(truth, times, msg.t)
                bad += math.hypot(msg.x - tx, msg.y - ty) > outlier_dist
            else:
                rejected += 1
        elif kind == "imu":
            loc.on_imu(msg)
        elif kind == "compass":
            loc.on_compass(msg)
        else:
            loc.on_odom(msg)
            p = loc.get_pose()
            tx, ty, tth = _truth_at(truth, times, p.t)
            last_err = math.hypot(p.x - tx, p.y - ty)
            if p.t - t0 >= warmup:
                errors.append(last_err)
                heading_sq += wrap_angle(p.theta - tth) ** 2
    n = max(len(errors), 1)
    rmse = math.sqrt(sum(e * e for e in errors) / n)
    final = errors[-1] if errors else math.nan
    return Score(rmse, max(errors, default=0.0), final, math.sqrt(heading_sq / n), outage_end, accepted, rejected, bad)
