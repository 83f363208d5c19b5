"""Robots' bodies on one field, as discs: a step that would take a robot into another stops at contact.

A robot that drives into another does not push it: its wheels turn on (the encoders
count them) while it stays at the contact circle. Along the other's body it slides
only as far as friction lets it: the part of its step across the line between the
centres, less FRICTION times the part the other held back, so a push near head-on
stalls and a glancing one slides round. Odometry sees a robot that moves; only the
camera sees it held, as on a real field. A step away from a body it overlaps (put
down on it, or driven into by the other) is free, and so is one that keeps its
distance.

Pure: positions in, a position out.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import NamedTuple

FRICTION = 0.5  # [-] sliding along another body: the travel across it lost per unit of travel into it held back


class Disc(NamedTuple):
    """A robot's footprint on the field (map frame)."""

    x: float  # [m] centre
    y: float  # [m]
    radius: float  # [m]


def block(x0: float, y0: float, x1: float, y1: float, radius: float, others: Mapping[str, Disc]) -> tuple[float, float, list[str]]:
    """Where a body of `radius` that a step takes from (x0, y0) to (x1, y1) ends among `others`, and the
    names of those it met: a step that would end closer to a disc than it started, and within contact of
    it, goes into it only as far as contact (no further, if it overlapped already), and across the line
    between the centres by what is left after friction."""
    x, y, met = x1, y1, []
    for name, o in others.items():
        reach = radius + o.radius
        if math.hypot(x - o.x, y - o.y) >= reach:
            continue
        nx, ny = x0 - o.x, y0 - o.y  # from the other's centre to where the step started
        start = math.hypot(nx, ny)
        if start < 1e-12:  # on its centre: no way out is closer
            continue
        nx, ny = nx / start, ny / start
        dx, dy = x - x0, y - y0
        into = dx * nx + dy * ny  # < 0: towards the other
        if into >= 0.0:
            continue
        met.append(name)
        allowed = -max(start - reach, 0.0)  # into it as far as contact
        tx, ty = dx - into * nx, dy - into * ny  # across the line between the centres
        across = math.hypot(tx, ty)
        keep = max(across - FRICTION * (allowed - into), 0.0) / across if across > 0.0 else 0.0
        x, y = x0 + allowed * nx + keep * tx, y0 + allowed * ny + keep * ty
    return x, y, met
