"""Other robots on the way: give way in a lane to the right or by slowing, drive round them keeping right, step aside,
or wait.

Pure: the robot's position, its way (the points it drives through next) and the other robots' bodies (position,
footprint, velocity, and the next points of their own way when they tell them) come in as arguments. Another robot's
centre is kept `reach` = both footprints plus [field] margin plus BUFFER from this one's. Each pose:

1. Right of way goes to the robot whose id sorts first (as text: "r1" before "r2", "r10" before "r2"). A robot
   with the right of way that moves is seen where it is and where it goes within SWEEP (its swept disc): along the
   way it tells at its speed (a robot keeping right of this one is seen passing beside it, a crossing one where it
   crosses), else along its velocity. Any other robot (without the right of way, or standing) is seen where it is. So
   the robot without the right of way clears the other's course; the one with it only goes round where the other is:
   each pair agrees who gives way.
2. When a robot (swept) lies within `reach` of the way's next LOOK_AHEAD metres and every such robot has the right of
   way and moves (it crosses the way), the robot keeps going if, driving on along its way at full speed, it keeps
   `reach` from every robot (those with the right of way going on as foreseen, the rest standing) for HORIZON seconds.
   Else it takes the first of the lanes LANES right of its way (through a corner LANE_AT along the way to the way's
   next point) that keeps so at full speed: keeping right, as the robots with the right of way do (3.). Else it lets
   them pass by slowing: the largest of SCALES of its speed at which, along its way, it keeps so.
3. Else it takes a detour to the first point of its way clear of every robot, planned by the visibility graph round
   the robots and the field's obstacles near it, inside the field's edges (moved in by the footprint and margin): a
   robot near the edge goes round on the side that has room. Each robot's shape is moved BIAS to the left of the line
   from this robot to it (and grown by 2 BIAS, so that it still holds it with BIAS to spare): the way round it on the
   right is the shorter, and two robots meeting head-on both keep right. A detour taken earlier (the way's points
   before `base`) is kept while nothing is in it; once something is, the new detour replaces it whole, rejoining the
   goal's own way (never a corner of the old detour: detours do not pile up into loops).
4. It waits (standing) when no detour exists (a robot stands on the goal, once within GOAL_NEAR of it; or the way round
   is closed by the field's obstacles or edges); the caller bounds the wait ([navigator] robot_wait). A robot on the
   goal that has the right of way and stands may be waiting for this one to leave its own goal: once per goal (when
   the caller allows it) this robot steps aside, off the line between them, to let it pass.
The motor's guard stays under every command: what this misses, it stops.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from zenav.common.config import Field
from zenav.common.field import Point, Shape, circle_shape, hull, polygon_shape
from zenav.services.navigator.planner import Planner

BUFFER = 0.03  # [m] kept clear of another robot beyond both footprints and the margin (its pose's noise, its motion)
BIAS = 0.03  # [m] each robot's disc moved left (and grown) by this for the detour: passing on the right is shorter
SWEEP = 1.5  # [s] a moving robot with the right of way is kept clear of where it will be within this long
LOOK_AHEAD = 1.0  # [m] of the way checked for robots in it
MOVING = 0.03  # [m/s] a robot slower than this stands
GOAL_NEAR = 0.6  # [m] a robot on the goal counts only once this close to the goal (two swapping robots: not at the start)
DISC_SIDES = 8  # sides of the polygon a robot's disc is planned round as
SCALES = (0.8, 0.6, 0.45, 0.3, 0.15)  # [-] the slower speeds tried, as fractions of the goal's, to let a crossing robot pass
HORIZON = 3.0  # [s] a robot letting others pass (driving on, in a lane, slower) keeps clear of their foreseen course this long
STEP = 0.1  # [s] the prediction's time step
ASIDE = 0.1  # [m] a step aside goes this much farther than `reach` + BIAS off the line (its point may be passed early)
LANES = (0.1, 0.2, 0.3, 0.4)  # [m] how far right of the way the lanes tried at full speed (before slowing) pass
LANE_AT = 1.0  # [m] a lane's corner lies this far along the way (at most half way to its next point)
NEARBY = 1.0  # [m] the field's obstacles this close to a detour's straight way are planned round with the robots


@dataclass(frozen=True)
class Other:
    """Another robot's body: where it is, its footprint, its velocity."""

    name: str
    x: float  # [m] map frame
    y: float  # [m]
    radius: float  # [m] footprint
    vx: float = 0.0  # [m/s] map frame
    vy: float = 0.0  # [m/s]
    way: tuple[Point, ...] = ()  # the next points it drives through, as it tells them (empty: not told)

    @property
    def moving(self) -> bool:
        """Whether it drives (not slower than MOVING)."""
        return math.hypot(self.vx, self.vy) >= MOVING

    def at(self, t: float) -> Point:
        """Where it will be in `t` [s] driving on at its speed: along its way (standing at its end), else its velocity."""
        if self.way:
            return along((self.x, self.y), self.way, math.hypot(self.vx, self.vy) * t)
        return (self.x + self.vx * t, self.y + self.vy * t)


@dataclass(frozen=True)
class Decision:
    """What to do on this pose: drive on (perhaps slower), wait for a robot, or take a detour round robots."""

    wait: str = ""  # the robot waited for ("": none)
    why: str = ""  # why it waits or slows, as text for nav/state
    detour: tuple[Point, ...] | None = None  # the way round the robots, its last point the old way's point `rejoin`
    rejoin: int = 0  # the old way's point the detour ends on (the rest of the old way follows it)
    scale: float = 1.0  # [-] the fraction of its speed to drive at (< 1: letting a crossing robot pass)
    aside: bool = False  # the detour steps aside for a robot on the goal

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
        self.field = field  # the field's planner: detours keep inside its edges and clear of its obstacles

    def reach(self, o: Other) -> float:
        """[m] how close the two centres may come."""
        return self.radius + o.radius + self.margin + BUFFER

    def decide(
        self, here: Point, way: Sequence[Point], others: Sequence[Other], speed: float = 0.2, aside: bool = False, base: int = 0
    ) -> Decision:
        """What to do at `here` driving through `way` at `speed` [m/s] among `others`; `aside`: it may step aside; `base`:
        the way's first point of the goal's own (those before it: a detour taken earlier, replaced whole if blocked)."""
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
        kept = [(q, self.reach(o) + BIAS) for o in others for q in self.swept(o)]  # each place another robot takes, how far off
        k = next((base + i for i, p in enumerate(way[base:]) if all(math.dist(p, q) >= r for q, r in kept)), None)
        if k is None:
            taken = min(others, key=lambda o: math.dist(way[-1], (o.x, o.y)))
            step = self._aside(here, taken, others) if aside and taken.name < self.robot and not taken.moving else None
            if step is not None:
                return Decision(detour=(step, way[-1]), rejoin=len(way) - 1, aside=True)
            return Decision(taken.name, f"waiting for robot {taken.name} to leave the goal")
        if all(o.name < self.robot and o.moving for o in near):
            if self._clear(here, way, others, speed):
                return Decision()
            lanes = (self._lane(here, way[base:], d) for d in LANES)
            lane = next((w for w in lanes if w is not None and self._clear(here, w, others, speed)), None)
            if lane is not None:
                return Decision(detour=lane, rejoin=base)
            scale = next((f for f in SCALES if self._clear(here, way, others, f * speed)), None)
            if scale is not None:
                return Decision(why=f"slowing for robot {first.name} to pass", scale=scale)
        return self._detour(here, way, k, others, first)

    def swept(self, o: Other) -> list[Point]:
        """Where another robot will be: a robot with the right of way that moves, where it goes within SWEEP [s] (Other.at,
        sampled); any other, where it is."""
        if o.name >= self.robot or not o.moving:
            return [(o.x, o.y)]
        return [o.at(SWEEP * s) for s in (0.0, 0.25, 0.5, 0.75, 1.0)]

    def _lane(self, here: Point, way: Sequence[Point], d: float) -> tuple[Point, Point] | None:
        """The way to its next point through a corner `d` [m] right of it, LANE_AT along it (None: the point is closer
        than 2 `d`, or the corner is outside the field's edges or blocked by its obstacles)."""
        b = way[0]
        n = math.dist(here, b)
        if n < 2.0 * d:
            return None
        f = min(LANE_AT, n / 2.0) / n
        ux, uy = (b[0] - here[0]) / n, (b[1] - here[1]) / n
        p = (here[0] + (b[0] - here[0]) * f + uy * d, here[1] + (b[1] - here[1]) * f - ux * d)
        if self.field is not None and not (self._within(p) and self.field.free(here, p) and self.field.free(p, b)):
            return None
        return (p, b)

    def _clear(self, here: Point, way: Sequence[Point], others: Sequence[Other], speed: float) -> bool:
        """Whether driving along `way` at `speed` [m/s] keeps `reach` from every other for HORIZON [s] (those with the
        right of way that move going on as predicted, the rest standing)."""
        ts = np.arange(0.0, HORIZON + STEP / 2, STEP).tolist()
        return all(
            math.dist(along(here, way, speed * t), o.at(t) if o.name < self.robot else (o.x, o.y)) >= self.reach(o)
            for t in ts
            for o in others
        )

    def _detour(self, here: Point, way: Sequence[Point], k: int, others: Sequence[Other], first: Other) -> Decision:
        """The way round the robots (and the field's obstacles near it) to the way's point k, or a wait for `first`."""
        area = self.field.area if self.field is not None else Field(enabled=False)
        shapes = [self._shape(here, o) for o in others]
        if self.field is not None:
            shapes += [s for s in self.field.shapes if s.segment_clearance(here, way[k]) < NEARBY]
        try:
            points = Planner(area, self.radius + self.margin, DISC_SIDES, shapes).plan(here, way[k])
        except ValueError:  # NoPath: walled in by robots, obstacles and edges
            return Decision(first.name, f"waiting for robot {first.name}: no way round it")
        if self.field is not None and not all(self.field.free(a, b) for a, b in zip([here, *points[:-1]], points)):
            return Decision(first.name, f"waiting for robot {first.name}: no way round it clear of the field's obstacles")
        return Decision(detour=tuple(points), rejoin=k)

    def _shape(self, here: Point, o: Other) -> Shape:
        """Another robot as a shape to plan round (the planner adds this robot's footprint and the margin): its disc
        (swept: the hull of its discs where it goes), moved BIAS left of the line from `here` to it and grown by
        BUFFER and 2 BIAS."""
        dx, dy = o.x - here[0], o.y - here[1]
        n = math.hypot(dx, dy) or 1.0
        sx, sy = -dy / n * BIAS, dx / n * BIAS  # left of the line to it
        r = o.radius + BUFFER + 2.0 * BIAS
        swept = self.swept(o)
        if len(swept) == 1:
            return circle_shape(f"robot {o.name}", (o.x + sx, o.y + sy, r))
        ring = [(r * math.cos(a), r * math.sin(a)) for a in np.linspace(0.0, 2.0 * math.pi, DISC_SIDES, endpoint=False)]
        return polygon_shape(f"robot {o.name}", hull([(x + sx + u, y + sy + v) for x, y in swept for u, v in ring]))

    def _aside(self, here: Point, o: Other, others: Sequence[Other]) -> Point | None:
        """Where to step off the line from `o` to here (to the right facing it, else to the left) so that it can drive
        through here: `reach` + BIAS + ASIDE off the line, inside the field's edges, clear of its obstacles and of the others."""
        dx, dy = here[0] - o.x, here[1] - o.y
        n = math.hypot(dx, dy) or 1.0
        d = self.reach(o) + BIAS + ASIDE
        for side in (1.0, -1.0):  # facing o (heading -d), its right is (-dy, dx) / n
            p = (here[0] - side * dy / n * d, here[1] + side * dx / n * d)
            if any(math.dist(p, (q.x, q.y)) < self.reach(q) for q in others) or not self._within(p):
                continue
            if self.field is None or self.field.free(here, p):
                return p
        return None

    def _within(self, p: Point) -> bool:
        """Whether p lies inside the field's edges (moved in by the footprint and margin)."""
        box = self.field.box if self.field is not None else None
        return box is None or (box[0] <= p[0] <= box[2] and box[1] <= p[1] <= box[3])


def along(here: Point, way: Sequence[Point], length: float) -> Point:
    """The point `length` [m] along the way from `here` (its last point past its end)."""
    legs = prefix(here, way, length)
    return legs[-1][1] if legs else here
