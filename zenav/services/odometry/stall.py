"""A wheel commanded to turn whose encoder shows nothing: a frozen encoder or a stalled wheel.

Pure: each encoder step comes in with the wheel speeds commanded while its counts were
taken (the encoder sample's `cmd_left`, `cmd_right`). A wheel counts as silent once it
should have turned `min_ticks` ticks at its commanded speed and `min_time` has passed
without one tick; from then on the travel it was commanded is reported as unmeasured,
so the odometry's covariance (and the localizer's) grows by it instead of trusting a
count that says "still".
"""

from __future__ import annotations

import math
from typing import NamedTuple


class StallParams(NamedTuple):
    stall_speed: float  # [rad/s] a wheel commanded slower than this may rightly not turn (deadband)
    min_ticks: float  # ticks the commanded speed must have turned the wheel before silence counts
    min_time: float  # [s] and the least time of silence
    ticks_per_rad: float  # encoder ticks per radian of wheel
    radius: float  # [m] wheel radius


class Watch(NamedTuple):
    """Per wheel (left, right): since when it has been commanded but silent, and how far it was told to turn."""

    since: tuple[float | None, float | None] = (None, None)  # [s]
    owed: tuple[float, float] = (0.0, 0.0)  # [rad] commanded turn since then
    silent: tuple[bool, bool] = (False, False)  # each encoder silent at the newest step


def step(
    w: Watch, p: StallParams, t: float, dt: float, ticks: tuple[int, int], cmd: tuple[float, float]
) -> tuple[Watch, tuple[float, float], tuple[bool, bool]]:
    """One encoder step ending at t [s], dt [s] long, with each wheel's tick count change and its command [rad/s].

    Returns the new watch, each wheel's unmeasured travel this step [m] and whether it is silent.
    """
    since, owed, unmeasured, silent = list(w.since), list(w.owed), [0.0, 0.0], [False, False]
    for i in (0, 1):
        speed = cmd[i]
        if ticks[i] != 0 or abs(speed) < p.stall_speed:
            since[i], owed[i] = None, 0.0
            continue
        start = since[i]
        if start is None:
            start = since[i] = t - dt
        owed[i] += abs(speed) * dt
        if owed[i] * p.ticks_per_rad >= p.min_ticks and t - start >= p.min_time:
            silent[i] = True
            unmeasured[i] = abs(speed) * dt * p.radius
    flags = (silent[0], silent[1])
    return Watch((since[0], since[1]), (owed[0], owed[1]), flags), (unmeasured[0], unmeasured[1]), flags


def params(ticks_per_rev: int, radius: float, stall_speed: float, min_ticks: float, min_time: float) -> StallParams:
    return StallParams(stall_speed, min_ticks, min_time, ticks_per_rev / (2.0 * math.pi), radius)
