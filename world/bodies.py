"""Robots' bodies on one field, as discs: a step that would take a robot into another, or through
the field's walls, stops at contact.

A robot that drives into another does not push it: its wheels turn on (the encoders
count them) while it stays at the contact circle. Along the other's body it slides
only as far as friction lets it: the part of its step across the line between the
centres, less FRICTION times the part the other held back, so a push near head-on
stalls and a glancing one slides round. A wall holds it the same way, across the
wall's normal. Odometry sees a robot that moves; only the camera sees it held, as on
a real field. A step away from a body or wall it overlaps (put down on it, or driven
into by the other) is free, and so is one that keeps its distance.

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


class Walls:
    """The field's walls: the inner faces of a rectangle (map frame), each kept as (name, inward unit normal
    nx, ny, offset): (x, y) lies nx x + ny y + offset [m] inside it. Built once, read at every step."""

    __slots__ = ("faces",)

    def __init__(self, x_min: float, x_max: float, y_min: float, y_max: float) -> None:  # [m]
        self.faces = (
            ("wall x_min", 1.0, 0.0, -x_min),
            ("wall x_max", -1.0, 0.0, x_max),
            ("wall y_min", 0.0, 1.0, -y_min),
            ("wall y_max", 0.0, -1.0, y_max),
        )


def _held(x0: float, y0: float, x: float, y: float, nx: float, ny: float, room: float) -> tuple[float, float] | None:
    """Where a step from (x0, y0) to (x, y) ends against a contact whose unit normal (nx, ny) points from it
    to (x0, y0), with `room` [m] between them at the start (negative: overlapping); None if it moves away:
    into it as far as contact (no further, if it overlapped already), and across the normal by what is
    left after friction."""
    dx, dy = x - x0, y - y0
    into = dx * nx + dy * ny  # < 0: towards the contact
    if into >= 0.0:
        return None
    allowed = -max(room, 0.0)
    tx, ty = dx - into * nx, dy - into * ny  # across the normal
    across = math.hypot(tx, ty)
    keep = max(across - FRICTION * (allowed - into), 0.0) / across if across > 0.0 else 0.0
    return x0 + allowed * nx + keep * tx, y0 + allowed * ny + keep * ty


def block(
    x0: float, y0: float, x1: float, y1: float, radius: float, others: Mapping[str, Disc], walls: Walls | None = None
) -> tuple[float, float, list[str]]:
    """Where a body of `radius` that a step takes from (x0, y0) to (x1, y1) ends among `others` and inside
    `walls`, and the names of those it met (a wall's: "wall x_max" and so on): a step that would end
    closer to a disc or a wall than it started, and within contact of it, is held there (_held)."""
    x, y = x1, y1
    met: list[str] = []
    for name, o in others.items():
        reach = radius + o.radius
        if math.hypot(x - o.x, y - o.y) >= reach:
            continue
        nx, ny = x0 - o.x, y0 - o.y  # from the other's centre to where the step started
        start = math.hypot(nx, ny)
        if start < 1e-12:  # on its centre: no way out is closer
            continue
        end = _held(x0, y0, x, y, nx / start, ny / start, start - reach)
        if end is not None:
            (x, y) = end
            met.append(name)
    if walls is not None:
        for name, nx, ny, offset in walls.faces:
            if nx * x + ny * y + offset >= radius:
                continue
            end = _held(x0, y0, x, y, nx, ny, nx * x0 + ny * y0 + offset - radius)
            if end is not None:
                (x, y) = end
                met.append(name)
    return x, y, met
