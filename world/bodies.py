"""Robots' bodies on one field, as discs: a step that would take a robot into another stops at contact.

A robot that drives into another does not push it: its wheels turn on (the encoders
count them) while it stays at the contact circle, sliding round the other's body
where it came at an angle. Odometry sees a robot that moves; only the camera sees it
stopped, as on a real field. A step away from a body it overlaps (put down on it, or
driven into by the other) is free, and so is one that keeps its distance.

Pure: positions in, a position out.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import NamedTuple


class Disc(NamedTuple):
    """A robot's footprint on the field (map frame)."""

    x: float  # [m] centre
    y: float  # [m]
    radius: float  # [m]


def block(x0: float, y0: float, x1: float, y1: float, radius: float, others: Mapping[str, Disc]) -> tuple[float, float, list[str]]:
    """Where a body of `radius` that a step takes from (x0, y0) to (x1, y1) ends among `others`, and the
    names of those it met. A step that ends closer to a disc than it started, and within contact of it,
    ends on the contact circle (or, already inside it, at the distance it started at) on the line from
    that disc's centre to where the step would have ended: the motion across that line is kept."""
    x, y, met = x1, y1, []
    for name, o in others.items():
        reach = radius + o.radius
        dx, dy = x - o.x, y - o.y
        d = math.hypot(dx, dy)
        start = math.hypot(x0 - o.x, y0 - o.y)
        if d >= reach or d >= start:
            continue
        met.append(name)
        keep = min(reach, start)  # [m] the closest it may end: contact, or where it was if it overlapped already
        if d < 1e-12:  # straight onto the other's centre: back where it came from
            x, y = x0, y0
        else:
            x, y = o.x + dx * keep / d, o.y + dy * keep / d
    return x, y, met
