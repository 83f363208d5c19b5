"""Robots' bodies on one field, as discs: a step that would take a robot into another, or through
the field's walls, stops at contact. Against the walls a robot may have a chassis instead, a
rectangle that squares up against a wall it is driven into.

A robot that drives into another does not push it: its wheels turn on (the encoders
count them) while it stays at the contact circle. Along the other's body it slides
only as far as friction lets it: the part of its step across the line between the
centres, less FRICTION times the part the other held back, so a push near head-on
stalls and a glancing one slides round. A wall holds it the same way, across the
wall's normal. Odometry sees a robot that moves; only the camera sees it held, as on
a real field. A step away from a body or wall it overlaps (put down on it, or driven
into by the other) is free, and so is one that keeps its distance.

A chassis (`Chassis`) meets a wall at a corner first. Its wheels do not skid sideways,
so the step it takes is the one nearest the wheels' travel (each wheel slips by the
difference) that takes no corner past the wall (`chassis_travel`): driven squarely
into a wall, the wheel on the side that touched is held while the other drives on, and
the robot turns about the corner until its face is flat against the wall, as teams
square up to reset a heading; one that grazes a wall turns along it.

Pure: positions in, a position out.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import NamedTuple

from zenav.common.field import Shape

FRICTION = 0.5  # [-] sliding along another body: the travel across it lost per unit of travel into it held back
SLACK = 1e-12  # [m] a constraint met this closely is met (rounding)


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


class Chassis:
    """A robot's body against the walls: a rectangle centred on the middle of its wheels' axle. Built once, read at
    every step."""

    __slots__ = ("corner", "length", "width")

    def __init__(self, length: float, width: float) -> None:  # [m] along the heading, and across it
        self.length, self.width = length, width
        self.corner = math.hypot(length, width) / 2.0  # [m] from the centre to a corner


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
    x0: float,
    y0: float,
    x1: float,
    y1: float,
    radius: float,
    others: Mapping[str, Disc],
    walls: Walls | None = None,
    obstacles: Sequence[Shape] = (),
) -> tuple[float, float, list[str]]:
    """Where a body of `radius` that a step takes from (x0, y0) to (x1, y1) ends among `others`, the field's
    `obstacles` and inside `walls`, and the names of those it met (a wall's: "wall x_max" and so on; an obstacle's
    its name): a step that would end closer to a disc, an obstacle or a wall than it started, and within contact of
    it, is held there (_held), across the normal from the obstacle's nearest point."""
    x, y = x1, y1
    met: list[str] = []
    for shape in obstacles:
        if shape.clearance(x, y) >= radius:
            continue
        px, py = shape.nearest(x0, y0)
        nx, ny = x0 - px, y0 - py
        start = math.hypot(nx, ny)
        if start < 1e-12:
            continue
        room = shape.clearance(x0, y0) - radius
        end = _held(x0, y0, x, y, nx / start, ny / start, room)
        if end is not None:
            (x, y) = end
            met.append(shape.name)
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


def _corners(theta: float, chassis: Chassis) -> tuple[tuple[float, float], ...]:
    """The chassis's corners at heading theta, as offsets [m] from its centre (map frame)."""
    c, s = math.cos(theta), math.sin(theta)
    hl, hw = chassis.length / 2.0, chassis.width / 2.0
    return tuple((c * lx - s * ly, s * lx + c * ly) for lx, ly in ((hl, hw), (hl, -hw), (-hl, hw), (-hl, -hw)))


def chassis_travel(
    x: float, y: float, theta: float, d_left: float, d_right: float, track: float, chassis: Chassis, walls: Walls
) -> tuple[float, float, list[str]]:
    """The wheels' travel over the ground (left, right) [m] a step from (x, y, theta) can take with the chassis
    inside `walls`, nearest the travel (d_left, d_right) the wheels would make, and the walls that held it back.

    To first order in the step, a corner at offset r moves by ds h + dtheta perp(r) (ds the mean travel, h the
    heading, dtheta the turn, `track` apart): across a wall's inward normal n, it may come no closer than contact
    (no farther out, if the robot was put down across the wall). Each such bound is linear in the two travels:
    the nearest pair that keeps them all is a projection onto a convex polygon in the plane, found among the
    travel itself, its projections onto each bound's edge and the edges' crossings. Standing still keeps them all.
    """
    reach = (abs(d_left) + abs(d_right)) * (0.5 + chassis.corner / track) + SLACK  # the farthest a corner moves this step
    if _clear(x, y, walls, chassis.corner + reach):
        return d_left, d_right, []
    offsets = _corners(theta, chassis)
    hx, hy = math.cos(theta), math.sin(theta)
    bounds: list[tuple[str, float, float, float]] = []  # (wall, a, b, low): a d_left + b d_right >= low
    for name, nx, ny, offset in walls.faces:
        along = (nx * hx + ny * hy) / 2.0
        for rx, ry in offsets:
            room = nx * (x + rx) + ny * (y + ry) + offset
            if room < reach:
                turn = (ny * rx - nx * ry) / track  # n . perp(r), per metre of the travels' difference
                bounds.append((name, along - turn, along + turn, -max(room, 0.0)))
    met = list(dict.fromkeys(name for name, a, b, low in bounds if a * d_left + b * d_right < low - SLACK))
    if not met:
        return d_left, d_right, []
    left, right = _nearest(d_left, d_right, [(a, b, low) for _, a, b, low in bounds])
    return left, right, met


def _nearest(p: float, q: float, bounds: list[tuple[float, float, float]]) -> tuple[float, float]:
    """The point nearest (p, q) where a u + b v >= low for every (a, b, low) in `bounds` (a convex polygon that
    holds (0, 0)): (p, q) itself, or its projection onto one edge, or a crossing of two edges."""

    def keeps(u: float, v: float) -> bool:
        return all(a * u + b * v >= low - SLACK for a, b, low in bounds)

    if keeps(p, q):
        return p, q
    found, best = (0.0, 0.0), p * p + q * q
    candidates: list[tuple[float, float]] = []
    for a, b, low in bounds:
        norm = a * a + b * b
        if norm > 0.0:
            k = (low - a * p - b * q) / norm
            candidates.append((p + k * a, q + k * b))
    for i, (a1, b1, low1) in enumerate(bounds):
        for a2, b2, low2 in bounds[i + 1 :]:
            det = a1 * b2 - a2 * b1
            if abs(det) > 1e-12:
                candidates.append(((low1 * b2 - low2 * b1) / det, (a1 * low2 - a2 * low1) / det))
    for u, v in candidates:
        d = (u - p) ** 2 + (v - q) ** 2
        if d < best and keeps(u, v):
            found, best = (u, v), d
    return found


def chassis_inside(
    x0: float, y0: float, theta0: float, x: float, y: float, theta: float, chassis: Chassis, walls: Walls
) -> tuple[float, float]:
    """Where the chassis at (x, y, theta), after a step from (x0, y0, theta0), sits with no corner past a wall
    farther than it started (past none, if it started inside): moved back across each wall's normal as far as
    needed. `chassis_travel` bounds the step to first order; this takes up the rest (the arc's curve)."""
    if _clear(x, y, walls, chassis.corner):
        return x, y
    before, after = _corners(theta0, chassis), _corners(theta, chassis)
    for _, nx, ny, offset in walls.faces:
        allowed = min(min(nx * (x0 + rx) + ny * (y0 + ry) + offset for rx, ry in before), 0.0)
        deepest = min(nx * (x + rx) + ny * (y + ry) + offset for rx, ry in after)
        if deepest < allowed:
            x, y = x + (allowed - deepest) * nx, y + (allowed - deepest) * ny
    return x, y


def _clear(x: float, y: float, walls: Walls, margin: float) -> bool:
    """Whether (x, y) is more than `margin` [m] inside every wall."""
    return all(nx * x + ny * y + offset > margin for _, nx, ny, offset in walls.faces)
