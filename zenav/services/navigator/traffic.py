"""Other robots on the way: drive round them, keeping right; keep clear of where one with the right of way is going.

Pure: the robot's position, its way (the points it drives through next) and the other robots' bodies (position,
footprint, velocity) come in as arguments. Another robot's centre is kept `reach` = both footprints plus [field]
margin plus BUFFER from this one's. Each pose:

1. Right of way goes to the robot whose id sorts first (as text: "r1" before "r2", "r10" before "r2"). A robot
   with the right of way that moves is seen where it is and where its velocity takes it within SWEEP (its swept
   disc); any other robot (without the right of way, or standing) where it is. So the robot without the right of way
   clears the other's course; the one with it only goes round where the other is: each pair agrees who gives way.
2. When a robot (swept) lies within `reach` of the way's next LOOK_AHEAD metres, the robot takes a detour to the
   first point of its way clear of every robot, planned by the visibility graph round the robots. Each robot's shape
   is moved BIAS to the left of the line from this robot to it (and grown by 2 BIAS, so that it still holds it with
   BIAS to spare): the way round it on the right is the shorter, and two robots meeting head-on both keep right.
3. It waits (standing) when no detour exists (a robot stands on the goal, once within GOAL_NEAR of it; or the way round
   is closed by the field's obstacles or edges); the caller bounds the wait ([navigator] robot_wait).
The motor's guard stays under every command: what this misses, it stops.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from zenav.common.config import Field, Obstacle
from zenav.common.field import Point, hull
from zenav.services.navigator.planner import Planner

BUFFER = 0.03  # [m] kept clear of another robot beyond both footprints and the margin (its pose's noise, its motion)
BIAS = 0.03  # [m] each robot's disc moved left (and grown) by this for the detour: passing on the right is shorter
SWEEP = 2.0  # [s] a moving robot with the right of way is kept clear of where it will be within this long
LOOK_AHEAD = 1.0  # [m] of the way checked for robots in it
MOVING = 0.03  # [m/s] a robot slower than this stands
GOAL_NEAR = 0.6  # [m] a robot on the goal counts only once this close to the goal (two swapping robots: not at the start)
DISC_SIDES = 8  # sides of the polygon a robot's disc is planned round as


@dataclass(frozen=True)
class Other:
    """Another robot's body: where it is, its footprint, its velocity."""

    name: str
    x: float  # [m] map frame
    y: float  # [m]
    radius: float  # [m] footprint
    vx: float = 0.0  # [m/s] map frame
    vy: float = 0.0  # [m/s]

    @property
    def moving(self) -> bool:
        """Whether it drives (not slower than MOVING)."""
        return math.hypot(self.vx, self.vy) >= MOVING


@dataclass(frozen=True)
class Decision:
    """What to do on this pose: drive on, wait for a robot, or take a detour round robots."""

    wait: str = ""  # the robot waited for ("": none)
    why: str = ""  # why, as text for nav/state
    detour: tuple[Point, ...] | None = None  # the way round the robots, its last point the old way's point `rejoin`
    rejoin: int = 0  # the old way's point the detour ends on (the rest of the old way follows it)

    @property
    def driving(self) -> bool:
        """Whether the robot drives (on its way or a detour)."""
        return not self.wait


def prefix(here: Point, way: Sequence[Point], length: float) -> list[tuple[Point, Point]]:
    """The legs of the way from `here`, cut `length` [m] along it."""
    legs: list[tuple[Point, Point]] = []
    left, a = length, here
    for b in way:
        d = math.dist(a, b)
        if d >= left:
            t = left / d if d > 0.0 else 0.0
            legs.append((a, (a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t)))
            break
        legs.append((a, b))
        left -= d
        a = b
    return legs


def segment_distance(p: Point, a: Point, b: Point) -> float:
    """[m] from p to the segment a-b."""
    dx, dy = b[0] - a[0], b[1] - a[1]
    n = dx * dx + dy * dy
    t = 0.0 if n < 1e-18 else min(max(((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / n, 0.0), 1.0)
    return math.hypot(p[0] - a[0] - t * dx, p[1] - a[1] - t * dy)


class Traffic:
    """One robot's view of the others: `decide` on each pose."""

    def __init__(self, robot: str, radius: float, margin: float, field: Planner | None = None) -> None:
        self.robot, self.radius, self.margin = robot, radius, margin  # [m] its footprint, the field's margin
        self.field = field  # the field's planner: a detour's legs keep clear of its obstacles, its points inside its edges

    def reach(self, o: Other) -> float:
        """[m] how close the two centres may come."""
        return self.radius + o.radius + self.margin + BUFFER

    def decide(self, here: Point, way: Sequence[Point], others: Sequence[Other]) -> Decision:
        """What to do at `here` driving through `way` among `others`."""
        if not way or not others:
            return Decision()
        if math.dist(here, way[-1]) > GOAL_NEAR:  # far from the goal: a robot standing on it may well leave it first
            others = [o for o in others if math.dist(way[-1], (o.x, o.y)) >= self.reach(o) + BIAS]
            if not others:
                return Decision()
        legs = prefix(here, way, LOOK_AHEAD)
        near = [o for o in others if min(segment_distance(p, a, b) for p in self.swept(o) for a, b in legs) < self.reach(o)]
        if not near:
            return Decision()
        first = min(near, key=lambda o: o.name)
        clear = [all(math.dist(p, q) >= self.reach(o) + BIAS for o in others for q in self.swept(o)) for p in way]
        k = next((i for i, ok in enumerate(clear) if ok), None)
        if k is None:
            taken = min(others, key=lambda o: math.dist(way[-1], (o.x, o.y)))
            return Decision(taken.name, f"waiting for robot {taken.name} to leave the goal")
        try:
            planner = Planner(Field(enabled=False, obstacles=tuple(self._obstacle(here, o) for o in others)), self.radius, DISC_SIDES)
            points = planner.plan(here, way[k])
        except ValueError:  # NoPath; or two shapes the same (FieldError)
            return Decision(first.name, f"waiting for robot {first.name}: no way round it")
        if not self._on_field(here, points):
            return Decision(first.name, f"waiting for robot {first.name}: no way round it clear of the field's obstacles and edges")
        return Decision(detour=tuple(points), rejoin=k)

    def swept(self, o: Other) -> list[Point]:
        """Where another robot will be: a robot with the right of way that moves, along its velocity for SWEEP [s]
        (sampled); any other, where it is."""
        if o.name >= self.robot or not o.moving:
            return [(o.x, o.y)]
        return [(o.x + o.vx * SWEEP * s, o.y + o.vy * SWEEP * s) for s in (0.0, 0.25, 0.5, 0.75, 1.0)]

    def _obstacle(self, here: Point, o: Other) -> Obstacle:
        """Another robot as an obstacle to plan round: its disc (swept: the hull of its discs along its velocity), moved
        BIAS left of the line from `here` to it and grown by both the margin, BUFFER and 2 BIAS."""
        dx, dy = o.x - here[0], o.y - here[1]
        n = math.hypot(dx, dy) or 1.0
        sx, sy = -dy / n * BIAS, dx / n * BIAS  # left of the line to it
        r = o.radius + self.margin + BUFFER + 2.0 * BIAS
        swept = self.swept(o)
        if len(swept) == 1:
            return Obstacle(name=f"robot {o.name}", circle=(o.x + sx, o.y + sy, r))
        ring = [(r * math.cos(a), r * math.sin(a)) for a in np.linspace(0.0, 2.0 * math.pi, DISC_SIDES, endpoint=False)]
        pts = hull([(x + sx + u, y + sy + v) for x, y in (swept[0], swept[-1]) for u, v in ring])
        return Obstacle(name=f"robot {o.name}", polygon=pts)

    def _on_field(self, here: Point, points: Sequence[Point]) -> bool:
        """Whether a detour keeps clear of the field's obstacles, its corners within its edges."""
        f = self.field
        if f is None:
            return True
        box = f.box
        if box is not None and not all(box[0] <= x <= box[2] and box[1] <= y <= box[3] for x, y in points[:-1]):
            return False
        return all(f.free(a, b) for a, b in zip([here, *points[:-1]], points))

    def clear(self, here: Point, way: Sequence[Point], others: Sequence[Other]) -> bool:
        """Whether the way's next LOOK_AHEAD metres keep clear of every other robot."""
        legs = prefix(here, way, LOOK_AHEAD)
        return not legs or all(min(segment_distance((o.x, o.y), a, b) for a, b in legs) >= self.reach(o) for o in others)
