"""A wheel's position within its encoder tick, from the times its count changed.

Pure. An encoder's count is the wheel's travel rounded down to a tick (the sim's
`floor`, a quadrature counter's edges): count n means the wheel is in [n, n + 1)
ticks. A count that rises to n was crossing n at that moment, one that falls to n
was crossing n + 1. Between samples the edge time is unknown; it is taken at the
middle of the span the newest edge can have happened in (half the sample period,
or half a tick's time when several ticks came in one sample). Between edges the
wheel runs as a first-order motor (time constant `lag`) driven by the encoder
samples' commands: its speed approaches the command, so a wheel told to stop or to
turn back coasts on for a while, one told to slow down slows, one told to start
spins up. At each edge the modelled speed is scaled so that the model's travel since
the previous edge in the same direction matches the tick it made (the edges' speed
stands in where the two disagree by more than a factor of two). The estimate always
stays inside the tick the count says it is in: a wheel that stalls waits at the
tick's end, one that reverses jumps back no further than the new count's edge, and
before its first edge it holds at the baseline. Positions are kept as the fraction
of a tick above the count, so the counter's wrap-around never reaches a float.
"""

from __future__ import annotations

import math
from typing import NamedTuple

SCALE_LIMIT = 2.0  # the edges' speed corrects the modelled one by at most this factor either way


class Wheel(NamedTuple):
    """One wheel's sub-tick estimate at its newest sample."""

    frac: float = 0.0  # [ticks] estimated position above the count, in [0, 1]
    edge_t: float | None = None  # [s] estimated time of the newest count change; None: none since the baseline
    edge: float = 0.0  # [ticks] where that change happened, above the count: 0 rising, 1 falling
    speed: float = 0.0  # [ticks/s] signed, between the last two edges in one direction; 0: not known
    rate: float = 0.0  # [ticks/s] signed, the modelled speed at the newest sample
    run: float = 0.0  # [ticks] the modelled travel since the newest edge, not held inside the tick


def motor(rate: float, span: float, cmd: float, lag: float) -> tuple[float, float]:
    """(travel [ticks], speed at the end [ticks/s]) of a first-order motor at `rate` [ticks/s] commanded `cmd`
    [ticks/s] for `span` [s] with time constant `lag` [s] (0: it turns at the command at once)."""
    if lag <= 0.0:
        return cmd * span, cmd
    decay = math.exp(-span / lag)
    return cmd * span + (rate - cmd) * lag * (1.0 - decay), cmd + (rate - cmd) * decay


def _inside(frac: float) -> float:
    """The fraction held inside the tick."""
    return min(1.0, max(0.0, frac))


def step(w: Wheel, ticks: int, t: float, dt: float, cmd: float, lag: float) -> Wheel:
    """The estimate after a sample at t [s], dt [s] after the previous one, in which the count moved `ticks`
    while the wheel was commanded `cmd` [ticks/s]; `lag` [s]: the motors' time constant."""
    if ticks == 0:
        travel, rate = motor(w.rate, dt, cmd, lag)
        frac = w.frac if w.edge_t is None else _inside(w.frac + travel)  # before the first edge: the baseline
        return w._replace(frac=frac, rate=rate, run=w.run + travel)
    edge = 0.0 if ticks > 0 else 1.0
    edge_t = t - dt / (2.0 * abs(ticks))
    before, rate = motor(w.rate, dt - (t - edge_t), cmd, lag)  # up to the edge
    speed = 0.0
    if w.edge_t is not None and edge_t > w.edge_t:
        made = ticks + edge - w.edge  # [ticks] from the previous edge to this one
        if made * ticks > 0.0:  # both edges in one direction (0: the wheel turned back within the tick)
            speed = made / (edge_t - w.edge_t)
            modelled = (w.run + before) / (edge_t - w.edge_t)  # [ticks/s] the model's mean speed meanwhile
            scale = speed / modelled if modelled * speed > 0.0 else 0.0
            rate = rate * scale if 1.0 / SCALE_LIMIT <= scale <= SCALE_LIMIT else speed
    after, rate = motor(rate, t - edge_t, cmd, lag)
    return Wheel(_inside(edge + after), edge_t, edge, speed, rate, after)


def travel(old: Wheel, new: Wheel, ticks: int) -> float:
    """[ticks] the wheel's estimated travel between two samples whose counts differ by `ticks`."""
    return ticks + new.frac - old.frac
