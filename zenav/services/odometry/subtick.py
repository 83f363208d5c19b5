"""A wheel's position within its encoder tick, from the times its count changed.

Pure. An encoder's count is the wheel's travel rounded down to a tick (the sim's
`floor`, a quadrature counter's edges): count n means the wheel is in [n, n + 1)
ticks. A count that rises to n was crossing n at that moment, one that falls to n
was crossing n + 1. Between samples the edge time is unknown; it is taken at the
middle of the span the newest edge can have happened in (half the sample period,
or half a tick's time when several ticks came in one sample). From the last edge
the wheel runs on at the speed between its last two edges in the same direction, but
no faster than the encoder sample says it was commanded (a wheel told to slow down
slows), not at all once commanded to stop or turn back (or when the sample carries no
command), and always inside the tick the count says it is in: a wheel that stalls
waits at the tick's end, one that reverses jumps back no further than the new count's
edge, and after a reversal (or at the start) it holds at its edge until the next one
gives a speed. Positions are kept as the fraction of a tick above the count, so the
counter's wrap-around never reaches a float.
"""

from __future__ import annotations

import math
from typing import NamedTuple


class Wheel(NamedTuple):
    """One wheel's sub-tick estimate at its newest sample."""

    frac: float = 0.0  # [ticks] estimated position above the count, in [0, 1]
    edge_t: float | None = None  # [s] estimated time of the newest count change; None: none since the baseline
    edge: float = 0.0  # [ticks] where that change happened, above the count: 0 rising, 1 falling
    speed: float = 0.0  # [ticks/s] signed, between the last two edges in one direction; 0: not known


def _run(w: Wheel, frac: float, span: float, cmd: float) -> float:
    """The fraction `span` [s] on from `frac` at the edges' speed, no faster than commanded, inside the tick."""
    if w.speed * cmd <= 0.0:  # not known, or commanded to stop or to turn back: the wheel runs on no further
        return frac
    rate = min(abs(w.speed), abs(cmd))  # a wheel commanded slower slows down
    return min(1.0, max(0.0, frac + math.copysign(rate * span, w.speed)))


def step(w: Wheel, ticks: int, t: float, dt: float, cmd: float) -> Wheel:
    """The estimate after a sample at t [s], dt [s] after the previous one, in which the count moved `ticks`
    while the wheel was commanded `cmd` [ticks/s]."""
    if ticks == 0:
        return w._replace(frac=_run(w, w.frac, dt, cmd))
    edge = 0.0 if ticks > 0 else 1.0
    edge_t = t - dt / (2.0 * abs(ticks))
    speed = 0.0
    if w.edge_t is not None and edge_t > w.edge_t:
        travel = ticks + edge - w.edge  # [ticks] from the previous edge to this one
        if travel * ticks > 0.0:  # both edges in one direction (0: the wheel turned back within the tick)
            speed = travel / (edge_t - w.edge_t)
    out = Wheel(edge, edge_t, edge, speed)
    return out._replace(frac=_run(out, edge, t - edge_t, cmd))


def travel(old: Wheel, new: Wheel, ticks: int) -> float:
    """[ticks] the wheel's estimated travel between two samples whose counts differ by `ticks`."""
    return ticks + new.frac - old.frac
