"""The global planner: the shortest way between two points among the field's obstacles, for a disc-shaped robot.

Pure: no bus, no clock. Each obstacle is inflated by the robot's clearance (footprint radius plus margin) into convex
polygons (field.inflate: never smaller than the truth); the field's edges move in by the same clearance. The shortest
way among polygons runs straight between their corners, so the plan is the shortest path on the visibility graph of
those corners (built once per field), found by A*: no plan enters an inflated obstacle, and its length is within the
approximation's 2 % of the shortest possible. A start or a goal that lies inside the approximation but clear of the
true inflated obstacle first steps out of it along the shortest way (the normal of the nearest side).
Every blocked-or-not test is Cyrus-Beck clipping of the segments against every convex piece at once (numpy).
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Sequence
from typing import cast

import numpy as np

from zenav.common.config import Field
from zenav.common.field import ARC_SIDES, Point, Polygon, Shape, inflate

INSIDE_EPS = 1e-7  # [m] pieces are shrunk by this for the tests: a segment along a side or through a corner is clear
ESCAPE_STEPS = 4  # steps out of overlapping pieces at most, for a start or goal inside the approximation


class NoPath(ValueError):
    """No way between the two points (walled in, or blocked by the field's edge)."""


class Planner:
    """The visibility graph of one field for one clearance; `plan` answers each start and goal."""

    def __init__(self, area: Field, clearance: float, arc_sides: int = ARC_SIDES, shapes: Sequence[Shape] | None = None) -> None:
        """`shapes`: planned round in place of the field's obstacles (None: the field's)."""
        self.area, self.clearance = area, clearance  # [m] footprint radius + margin
        self.shapes: tuple[Shape, ...] = area.shapes() if shapes is None else tuple(shapes)
        pieces: list[Polygon] = [poly for s in self.shapes for poly in inflate(s, clearance, arc_sides)]
        self.pieces = pieces
        c = clearance
        self.box = (area.x_min + c, area.y_min + c, area.x_max - c, area.y_max - c) if area.enabled else None
        normals: list[tuple[float, float]] = []
        offsets: list[float] = []
        starts: list[int] = []
        for poly in pieces:
            starts.append(len(offsets))
            for (x0, y0), (x1, y1) in zip(poly, poly[1:] + poly[:1], strict=True):
                nx, ny = y1 - y0, x0 - x1  # outward (counter-clockwise polygon)
                n = math.hypot(nx, ny)
                normals.append((nx / n, ny / n))
                offsets.append((nx * x0 + ny * y0) / n - INSIDE_EPS)
        self._n = np.array(normals, dtype=float).reshape(-1, 2)
        self._c = np.array(offsets, dtype=float)
        self._starts = np.array(starts, dtype=np.intp)
        nodes, sides = [], []
        for poly in pieces:
            for k, p in enumerate(poly):
                if self._usable(p):
                    nodes.append(p)
                    sides.append((poly[k - 1], poly[(k + 1) % len(poly)]))
        self.nodes = np.array(nodes, dtype=float).reshape(-1, 2)
        self._prev = np.array([s[0] for s in sides], dtype=float).reshape(-1, 2)
        self._next = np.array([s[1] for s in sides], dtype=float).reshape(-1, 2)
        self.edges: list[list[tuple[int, float]]] = [[] for _ in nodes]
        for i in range(len(nodes) - 1):
            js = np.arange(i + 1, len(nodes))
            js = js[self._tangent(js, self.nodes[i]) & self._tangent(np.full(len(js), i), self.nodes[js])]
            if len(js) == 0:
                continue
            ok = js[~self.blocked(np.repeat(self.nodes[i : i + 1], len(js), axis=0), self.nodes[js])]
            for j, d in zip(ok.tolist(), np.hypot(*(self.nodes[ok] - self.nodes[i]).T).tolist(), strict=True):
                self.edges[i].append((j, d))
                self.edges[j].append((i, d))

    # ------------------------------------------------------------ queries
    def blocked(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """For K segments a[k]-b[k] ((K, 2) arrays): whether each enters the interior of an inflated piece."""
        if len(self._c) == 0 or len(a) == 0:
            return np.zeros(len(a), dtype=bool)
        d = b - a
        num = self._c[None, :] - a @ self._n.T  # (K, E): > 0 where a lies inside the edge's half-plane
        den = d @ self._n.T
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # a side all but parallel: flat below
            ratio = num / den
        flat = np.abs(den) < 1e-15
        enter = np.where(den < 0.0, ratio, -np.inf)
        enter = np.where(flat & (num < 0.0), np.inf, enter)  # parallel to the side and outside it: never inside
        leave = np.where(den > 0.0, ratio, np.inf)
        t0 = np.maximum(np.maximum.reduceat(enter, self._starts, axis=1), 0.0)
        t1 = np.minimum(np.minimum.reduceat(leave, self._starts, axis=1), 1.0)
        return cast(np.ndarray, np.any(t0 < t1 - 1e-9, axis=1))

    def free(self, a: Point, b: Point) -> bool:
        """Whether the straight way a-b keeps clear of every inflated obstacle."""
        return not bool(self.blocked(np.array([a], dtype=float), np.array([b], dtype=float))[0])

    def plan(self, start: Point, goal: Point) -> list[Point]:
        """The points to drive through after `start`, the last one `goal`: [goal] when the straight way is free.
        NoPath when the goal cannot be reached."""
        head, s = self._escape(start)
        tail, g = self._escape(goal)
        tail.reverse()
        if self.free(s, g):
            return (_tidy(head + [s, g] + tail)[1:] or [goal]) if head or tail else [goal]
        n = len(self.nodes)
        dist_s = self._reach(s)
        dist_g = self._reach(g)
        best = np.hypot(*(self.nodes - np.array(g)).T)  # A*'s heuristic: straight to the goal
        cost = np.full(n, np.inf)
        came = np.full(n, -1, dtype=np.intp)
        heap: list[tuple[float, int]] = []
        for j, d in dist_s:
            cost[j] = d
            heapq.heappush(heap, (d + best[j], j))
        to_goal = dict(dist_g)
        found, found_cost = -1, math.inf
        while heap:
            f, i = heapq.heappop(heap)
            if f >= found_cost:
                break
            if i in to_goal and cost[i] + to_goal[i] < found_cost:
                found, found_cost = i, cost[i] + to_goal[i]
            for j, d in self.edges[i]:
                c = cost[i] + d
                if c < cost[j]:
                    cost[j], came[j] = c, i
                    heapq.heappush(heap, (c + best[j], j))
        if found < 0:
            raise NoPath(
                f"no way from ({start[0]:.3f}, {start[1]:.3f}) to ({goal[0]:.3f}, {goal[1]:.3f}) keeps {self.clearance:.3f} m clear"
            )
        way: list[Point] = []
        i = found
        while i >= 0:
            way.append((float(self.nodes[i, 0]), float(self.nodes[i, 1])))
            i = int(came[i])
        way.reverse()
        return _tidy(head + [s, *way, g] + tail)[1:]

    # ------------------------------------------------------------ internals
    def _usable(self, p: Point) -> bool:
        """A corner inside the field's inner box and inside no other piece."""
        if self.box is not None and not (self.box[0] <= p[0] <= self.box[2] and self.box[1] <= p[1] <= self.box[3]):
            return False
        return not self._inside(p).any()

    def _inside(self, p: Point) -> np.ndarray:
        """For each piece: whether p lies in its interior."""
        if len(self._c) == 0:
            return np.zeros(0, dtype=bool)
        out = self._n @ np.array(p, dtype=float) - self._c  # > 0: outside that side
        return np.maximum.reduceat(out, self._starts) < 0.0

    def _tangent(self, js: np.ndarray, frm: np.ndarray) -> np.ndarray:
        """For segments from `frm` (a point or (K, 2)) to nodes js: whether each grazes its node's piece there (both
        neighbouring corners on one side), the only way a shortest path turns at a corner."""
        d = self.nodes[js] - frm
        a = self._prev[js] - self.nodes[js]
        b = self._next[js] - self.nodes[js]
        ca = d[:, 0] * a[:, 1] - d[:, 1] * a[:, 0]
        cb = d[:, 0] * b[:, 1] - d[:, 1] * b[:, 0]
        return cast(np.ndarray, ca * cb >= -1e-12)

    def _reach(self, p: Point) -> list[tuple[int, float]]:
        """The nodes seen from p, with their distances."""
        if len(self.nodes) == 0:
            return []
        js = np.arange(len(self.nodes))
        here = np.array(p, dtype=float)
        js = js[self._tangent(js, here)]
        ok = js[~self.blocked(np.repeat(here[None, :], len(js), axis=0), self.nodes[js])]
        return list(zip(ok.tolist(), np.hypot(*(self.nodes[ok] - here).T).tolist(), strict=True))

    def _escape(self, p: Point) -> tuple[list[Point], Point]:
        """Steps out of the pieces p lies in, each the shortest way out of one, and where they end (p when in none)."""
        steps: list[Point] = []
        for _ in range(ESCAPE_STEPS):
            inside = np.flatnonzero(self._inside(p))
            if len(inside) == 0:
                break
            steps.append(p)
            p = _out_of(self.pieces[int(inside[0])], p)
        return steps, p


def _out_of(poly: Polygon, p: Point) -> Point:
    """The nearest point just outside a convex polygon from p inside it."""
    best, out = math.inf, p
    for (x0, y0), (x1, y1) in zip(poly, poly[1:] + poly[:1], strict=True):
        nx, ny = y1 - y0, x0 - x1
        n = math.hypot(nx, ny)
        depth = (nx * (x0 - p[0]) + ny * (y0 - p[1])) / n
        if depth < best:
            best, out = depth, (p[0] + (depth + 2 * INSIDE_EPS) * nx / n, p[1] + (depth + 2 * INSIDE_EPS) * ny / n)
    return out


def _tidy(points: Sequence[Point]) -> list[Point]:
    """Without repeated points (closer than 1 mm to the one before), nor points on the straight way past them; the
    last point kept as it is (a goal 1 mm from where an escape step ends is still the goal)."""
    out: list[Point] = []
    for i, p in enumerate(points):
        if out and math.dist(out[-1], p) <= 1e-3:
            if i == len(points) - 1 and len(out) > 1:
                out[-1] = p
            continue
        if len(out) >= 2:
            (ax, ay), (bx, by) = out[-2], out[-1]
            cross = (bx - ax) * (p[1] - ay) - (by - ay) * (p[0] - ax)
            ahead = (bx - ax) * (p[0] - bx) + (by - ay) * (p[1] - by)
            if abs(cross) <= 1e-9 * max(math.dist(out[-2], p), 1e-9) and ahead > 0.0:
                out.pop()
        out.append(p)
    return out


def length(start: Point, points: Sequence[Point]) -> float:
    """[m] of the way from start through the points."""
    return sum(math.dist(a, b) for a, b in zip([start, *points[:-1]], points, strict=True))


def clearance(shapes: Sequence[Shape], start: Point, points: Sequence[Point]) -> float:
    """[m] the least distance from the way (start, then the points) to any obstacle: inf without obstacles."""
    legs = list(zip([start, *points[:-1]], points, strict=True))
    return min((s.segment_clearance(a, b) for s in shapes for a, b in legs), default=math.inf)
