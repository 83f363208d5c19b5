"""The field's geometry: obstacles (polygons and discs), their checks, clearance, and inflation by the robot's footprint.

Pure: no I/O. A polygon is a tuple of (x, y) [m] corners in the map frame, either way round; it must be simple (no
edge crosses another, no repeated corner) and enclose an area. `clearance` is the distance from a point to a shape
(negative inside it); `segment_clearance` the least over a segment. `inflate` turns a shape into convex polygons
that hold every point within a radius of it (the configuration space of a disc-shaped robot), circles and rounded
corners approximated by circumscribed polygons: the approximation is never smaller than the truth.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

Point = tuple[float, float]
Polygon = tuple[Point, ...]
EPS = 1e-9  # [m] below this, lengths and areas are zero
ARC_SIDES = 16  # sides of the polygon a full circle of inflation is approximated by (circumscribed: at most 2 % larger)


class FieldError(ValueError):
    """A shape that cannot be an obstacle (degenerate, self-intersecting, outside the field, a duplicate)."""


@dataclass(frozen=True)
class Shape:
    """One obstacle: a simple polygon (counter-clockwise) or a disc, with the name errors and reports use."""

    name: str
    polygon: Polygon = ()
    circle: tuple[float, float, float] | None = None  # (x, y, r) [m]

    def clearance(self, x: float, y: float) -> float:
        """[m] from (x, y) to the shape's edge; negative inside it."""
        if self.circle is not None:
            cx, cy, r = self.circle
            return math.hypot(x - cx, y - cy) - r
        d = min(_point_segment(x, y, a, b) for a, b in _edges(self.polygon))
        return -d if contains(self.polygon, x, y) else d

    def nearest(self, x: float, y: float) -> Point:
        """The point of the shape's edge nearest (x, y)."""
        if self.circle is not None:
            cx, cy, r = self.circle
            d = math.hypot(x - cx, y - cy)
            return (cx + r, cy) if d < EPS else (cx + (x - cx) * r / d, cy + (y - cy) * r / d)
        return min((_project(x, y, a, b) for a, b in _edges(self.polygon)), key=lambda p: math.hypot(p[0] - x, p[1] - y))

    def segment_clearance(self, a: Point, b: Point) -> float:
        """[m] the least clearance of any point of the segment a-b (0 if it crosses the edge, negative if an end is inside)."""
        if self.circle is not None:
            cx, cy, r = self.circle
            return _point_segment(cx, cy, a, b) - r
        inside = min(self.clearance(*a), self.clearance(*b))
        if inside < 0.0:
            return inside
        if any(_cross(a, b, p, q) for p, q in _edges(self.polygon)):
            return 0.0
        edges = _edges(self.polygon)
        ends = min(min(_point_segment(a[0], a[1], p, q), _point_segment(b[0], b[1], p, q)) for p, q in edges)
        return min(ends, min(_point_segment(p[0], p[1], a, b) for p in self.polygon))

    def bounds(self) -> tuple[float, float, float, float]:
        """(x_min, y_min, x_max, y_max) [m]."""
        if self.circle is not None:
            cx, cy, r = self.circle
            return cx - r, cy - r, cx + r, cy + r
        xs, ys = [p[0] for p in self.polygon], [p[1] for p in self.polygon]
        return min(xs), min(ys), max(xs), max(ys)


def polygon_shape(name: str, points: Sequence[Sequence[float]]) -> Shape:
    """A checked polygon obstacle, made counter-clockwise; FieldError says what is wrong with it."""
    pts = tuple((float(p[0]), float(p[1])) for p in points)
    if any(len(p) != 2 for p in points):
        raise FieldError(f"{name}: each corner is [x, y]")
    if len(pts) < 3:
        raise FieldError(f"{name}: a polygon needs at least 3 corners, got {len(pts)}")
    if not all(math.isfinite(v) for p in pts for v in p):
        raise FieldError(f"{name}: corners must be finite numbers")
    for i, p in enumerate(pts):
        for j in range(i + 1, len(pts)):
            if math.dist(p, pts[j]) < EPS:
                raise FieldError(f"{name}: corners {i} and {j} are the same point {list(p)}: degenerate")
    edges = list(_edges(pts))
    n = len(edges)
    for i in range(n):
        for j in range(i + 1, n):
            if j == i + 1 or (i == 0 and j == n - 1):  # neighbours share a corner
                continue
            if _touch(*edges[i], *edges[j]):
                raise FieldError(f"{name}: edges {i} and {j} cross: the polygon is self-intersecting")
    area = signed_area(pts)
    if abs(area) < 1e-6:
        raise FieldError(f"{name}: the polygon encloses no area (its corners lie on a line): degenerate")
    return Shape(name, pts if area > 0.0 else pts[::-1])


def circle_shape(name: str, circle: Sequence[float]) -> Shape:
    """A checked disc obstacle from [x, y, r]."""
    if len(circle) != 3:
        raise FieldError(f"{name}: a circle is [x, y, r]")
    x, y, r = map(float, circle)
    if not all(math.isfinite(v) for v in (x, y, r)):
        raise FieldError(f"{name}: a circle's values must be finite numbers")
    if r <= EPS:
        raise FieldError(f"{name}: the radius must be > 0: degenerate")
    return Shape(name, circle=(x, y, r))


def check_layout(shapes: Sequence[Shape], bounds: tuple[float, float, float, float] | None) -> None:
    """Raise FieldError for an obstacle wholly outside `bounds` (x_min, y_min, x_max, y_max), or one given twice."""
    seen: dict[tuple[Any, ...], str] = {}
    for s in shapes:
        if bounds is not None:
            x0, y0, x1, y1 = s.bounds()
            if x1 <= bounds[0] or x0 >= bounds[2] or y1 <= bounds[1] or y0 >= bounds[3]:
                raise FieldError(f"{s.name}: lies outside the field (x {bounds[0]:g}..{bounds[2]:g}, y {bounds[1]:g}..{bounds[3]:g})")
        key = (s.circle,) if s.circle is not None else tuple(sorted(s.polygon))
        if key in seen:
            raise FieldError(f"{s.name}: the same obstacle as {seen[key]}: duplicate")
        seen[key] = s.name


def signed_area(pts: Polygon) -> float:
    """[m^2] positive when counter-clockwise."""
    return 0.5 * sum(a[0] * b[1] - b[0] * a[1] for a, b in _edges(pts))


def contains(pts: Polygon, x: float, y: float) -> bool:
    """Whether (x, y) lies inside the polygon (even-odd rule)."""
    inside = False
    for (x0, y0), (x1, y1) in _edges(pts):
        if (y0 > y) != (y1 > y) and x < x0 + (y - y0) * (x1 - x0) / (y1 - y0):
            inside = not inside
    return inside


def is_convex(pts: Polygon) -> bool:
    """Whether a counter-clockwise polygon is convex (no corner turns clockwise)."""
    n = len(pts)
    return all(_orient(pts[i], pts[(i + 1) % n], pts[(i + 2) % n]) >= -EPS for i in range(n))


def triangulate(pts: Polygon) -> list[Polygon]:
    """A simple counter-clockwise polygon as triangles (ear clipping)."""
    rest = list(pts)
    out: list[Polygon] = []
    while len(rest) > 3:
        n = len(rest)
        for i in range(n):
            a, b, c = rest[i - 1], rest[i], rest[(i + 1) % n]
            if _orient(a, b, c) <= EPS:
                continue
            if any(_in_triangle(p, a, b, c) for p in rest if p not in (a, b, c)):
                continue
            out.append((a, b, c))
            del rest[i]
            break
        else:  # numerically flat leftovers: no ear found
            break
    if len(rest) == 3 and abs(signed_area(tuple(rest))) > EPS:
        out.append(tuple(rest))
    return out


def inflate(shape: Shape, radius: float, sides: int = ARC_SIDES) -> list[Polygon]:
    """Convex counter-clockwise polygons whose union holds every point within `radius` [m] of the shape."""
    ring = _ring(radius, sides)
    if shape.circle is not None:
        cx, cy, r = shape.circle
        return [tuple((cx + ux * (r + radius), cy + uy * (r + radius)) for ux, uy in _ring(1.0, sides))]
    pieces = [shape.polygon] if is_convex(shape.polygon) else triangulate(shape.polygon)
    return [hull([(px + dx, py + dy) for px, py in piece for dx, dy in ring]) for piece in pieces]


def hull(points: Sequence[Point]) -> Polygon:
    """The convex hull, counter-clockwise (monotone chain), without collinear points."""
    pts = sorted(set(points))
    if len(pts) <= 2:
        return tuple(pts)

    def half(seq: Sequence[Point]) -> list[Point]:
        out: list[Point] = []
        for p in seq:
            while len(out) >= 2 and _orient(out[-2], out[-1], p) <= EPS:
                out.pop()
            out.append(p)
        return out

    lower, upper = half(pts), half(pts[::-1])
    return tuple(lower[:-1] + upper[:-1])


def _ring(radius: float, sides: int) -> list[Point]:
    """A regular polygon about the origin whose sides touch the circle of `radius` (it holds the circle)."""
    r = radius / math.cos(math.pi / sides)
    return [(r * math.cos(2.0 * math.pi * k / sides), r * math.sin(2.0 * math.pi * k / sides)) for k in range(sides)]


def _edges(pts: Polygon) -> list[tuple[Point, Point]]:
    return [(pts[i], pts[(i + 1) % len(pts)]) for i in range(len(pts))]


def _orient(a: Point, b: Point, c: Point) -> float:
    """Twice the signed area of a, b, c: > 0 when they turn counter-clockwise."""
    return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])


def _in_triangle(p: Point, a: Point, b: Point, c: Point) -> bool:
    return _orient(a, b, p) >= -EPS and _orient(b, c, p) >= -EPS and _orient(c, a, p) >= -EPS


def _on_segment(p: Point, a: Point, b: Point) -> bool:
    return _point_segment(p[0], p[1], a, b) < EPS


def _touch(a: Point, b: Point, c: Point, d: Point) -> bool:
    """Whether segments a-b and c-d share any point."""
    if _cross(a, b, c, d):
        return True
    return _on_segment(c, a, b) or _on_segment(d, a, b) or _on_segment(a, c, d) or _on_segment(b, c, d)


def _cross(a: Point, b: Point, c: Point, d: Point) -> bool:
    """Whether segments a-b and c-d cross properly (each one's ends strictly on either side of the other)."""
    d1, d2 = _orient(c, d, a), _orient(c, d, b)
    d3, d4 = _orient(a, b, c), _orient(a, b, d)
    return ((d1 > EPS and d2 < -EPS) or (d1 < -EPS and d2 > EPS)) and ((d3 > EPS and d4 < -EPS) or (d3 < -EPS and d4 > EPS))


def _project(x: float, y: float, a: Point, b: Point) -> Point:
    """The point of the segment a-b nearest (x, y)."""
    dx, dy = b[0] - a[0], b[1] - a[1]
    n = dx * dx + dy * dy
    t = 0.0 if n < EPS * EPS else max(0.0, min(1.0, ((x - a[0]) * dx + (y - a[1]) * dy) / n))
    return a[0] + t * dx, a[1] + t * dy


def _point_segment(x: float, y: float, a: Point, b: Point) -> float:
    """[m] from (x, y) to the segment a-b."""
    px, py = _project(x, y, a, b)
    return math.hypot(x - px, y - py)
