"""The safety layer under every command (Nav2's collision monitor): slow near, and stop before, what the footprint would meet.

Pure: the pose, the field's shapes and the other robots come in as arguments. The footprint is a disc, so a turn in
place never brings it closer to anything: only the forward speed is limited. The way ahead (behind, reversing) is
a straight ray from the robot's centre along its heading; `room` is how far the centre may go along it before the
footprint comes within `gap` of an obstacle, another robot's disc or (with `edges`) the field's edge. The speed is
capped to the one that brakes at `decel` within that room (sqrt(2 decel room)), and to zero once the room is gone;
moving away is never limited. What it limited, and why, is returned with the command.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from zenav.common.field import Shape

Disc = tuple[float, float, float]  # (x, y, radius) [m]


@dataclass(frozen=True)
class Limit:
    """A command after the guard: the speed allowed, and what held it back ("" when nothing did)."""

    v: float  # [m/s]
    omega: float  # [rad/s]
    what: str = ""  # what held it back ("": nothing), e.g. "obstacles[0] 'box'", "robot r2"
    room: float = math.inf  # [m] the centre may move this far before the footprint comes within the gap of it
    stopped: bool = False  # the forward speed was cut to zero
    ahead: bool = True  # it lies ahead (False: behind, reversing)

    @property
    def reason(self) -> str:
        """What held the command back and how far it is, as text ("" when nothing did)."""
        return f"{self.what} {self.room:.3f} m {'ahead' if self.ahead else 'behind'}" if self.what else ""


class Guard:
    """The field a robot of `radius` drives on: its shapes and (optionally) its edges."""

    def __init__(
        self,
        shapes: Sequence[Shape],
        radius: float,
        gap: float,
        decel: float,
        bounds: tuple[float, float, float, float] | None = None,
    ) -> None:
        self.shapes, self.radius, self.gap, self.decel, self.bounds = tuple(shapes), radius, gap, decel, bounds

    def limit(
        self, v: float, omega: float, x: float, y: float, theta: float, others: Sequence[tuple[str, Disc]] = (), doubt: float = 0.0
    ) -> Limit:
        """The command (v, omega) for a robot at (x, y, theta), its forward speed capped by the room ahead; `doubt` [m]
        is added to the gap (the pose's uncertainty)."""
        if v == 0.0:
            return Limit(v, omega)
        h = theta if v > 0.0 else theta + math.pi
        dx, dy = math.cos(h), math.sin(h)
        room, what = self.room(x, y, dx, dy, others, doubt)
        if room == math.inf:
            return Limit(v, omega)
        cap = math.sqrt(2.0 * self.decel * max(room, 0.0))
        if abs(v) <= cap:
            return Limit(v, omega)
        return Limit(math.copysign(cap, v), omega, what, max(room, 0.0), stopped=cap == 0.0, ahead=v > 0.0)

    def room(
        self, x: float, y: float, dx: float, dy: float, others: Sequence[tuple[str, Disc]] = (), doubt: float = 0.0
    ) -> tuple[float, str]:
        """[m] how far the centre may move along the unit direction (dx, dy) before the footprint comes within the gap
        (plus `doubt`) of something, and what that is (inf, "" when nothing is ahead)."""
        reach = self.radius + self.gap + doubt
        best, what = math.inf, ""
        for s in self.shapes:
            if s.circle is not None:
                d = _ray_disc(x, y, dx, dy, s.circle[0], s.circle[1], s.circle[2] + reach)
            else:
                d = _ray_polygon(x, y, dx, dy, s.polygon, reach)
            if d < best:
                best, what = d, s.name
        for name, (ox, oy, r) in others:
            d = _ray_disc(x, y, dx, dy, ox, oy, r + reach)
            if d < best:
                best, what = d, f"robot {name}"
        if self.bounds is not None:
            d, edge = _ray_box(x, y, dx, dy, self.bounds, reach)
            if d < best:
                best, what = d, edge
        return best, what


def position_sigma(cov: Sequence[float]) -> float:
    """[m] the position sigma along the worst axis of a row-major 3x3 (x, y, theta) covariance."""
    a, b, d = cov[0], (cov[1] + cov[3]) / 2.0, cov[4]
    return math.sqrt(max((a + d) / 2.0 + math.sqrt(((a - d) / 2.0) ** 2 + b * b), 0.0))


def _ray_disc(x: float, y: float, dx: float, dy: float, cx: float, cy: float, r: float) -> float:
    """[m] along the ray to where it enters the disc; 0 if it starts inside and heads further in; inf if it misses
    (or starts inside and heads out)."""
    ox, oy = x - cx, y - cy
    along = ox * dx + oy * dy  # < 0: the centre lies ahead
    c = ox * ox + oy * oy - r * r
    if c <= 0.0:
        return 0.0 if along < 0.0 else math.inf
    if along >= 0.0:
        return math.inf
    disc = along * along - c
    return math.inf if disc < 0.0 else -along - math.sqrt(disc)


def _ray_polygon(x: float, y: float, dx: float, dy: float, pts: tuple[tuple[float, float], ...], r: float) -> float:
    """[m] along the ray until it comes within r of the polygon (its edges' capsules; inside counts as within)."""
    best = math.inf
    n = len(pts)
    for i in range(n):
        (ax, ay), (bx, by) = pts[i], pts[(i + 1) % n]
        best = min(best, _ray_disc(x, y, dx, dy, ax, ay, r), _ray_band(x, y, dx, dy, ax, ay, bx, by, r))
    return best


def _ray_band(x: float, y: float, dx: float, dy: float, ax: float, ay: float, bx: float, by: float, r: float) -> float:
    """[m] along the ray to where it enters the rectangle of points within r of segment a-b, measured across it."""
    ex, ey = bx - ax, by - ay
    length = math.hypot(ex, ey)
    ux, uy = ex / length, ey / length  # along the segment
    nx, ny = -uy, ux
    off = (x - ax) * nx + (y - ay) * ny  # across, now
    rate = dx * nx + dy * ny  # across, per metre of travel
    pos = (x - ax) * ux + (y - ay) * uy  # along, now
    move = dx * ux + dy * uy
    if abs(off) <= r:
        if 0.0 <= pos <= length:
            return 0.0 if off * rate < 0.0 or off == 0.0 else math.inf  # within: held unless it moves away
        return math.inf  # beside the band's end: the corner discs answer
    if off * rate >= 0.0:
        return math.inf  # moving away or parallel
    t = (abs(off) - r) / abs(rate)
    p = pos + move * t
    return t if 0.0 <= p <= length else math.inf


def _ray_box(x: float, y: float, dx: float, dy: float, b: tuple[float, float, float, float], r: float) -> tuple[float, str]:
    """[m] along the ray until the disc comes within r of the field's edge (x_min, y_min, x_max, y_max), and which."""
    best, what = math.inf, ""
    for name, room, rate in (
        ("the field's edge x_min", x - b[0] - r, -dx),
        ("the field's edge x_max", b[2] - x - r, dx),
        ("the field's edge y_min", y - b[1] - r, -dy),
        ("the field's edge y_max", b[3] - y - r, dy),
    ):
        if rate > 0.0:
            d = max(room, 0.0) / rate
            if d < best:
                best, what = d, name
    return best, what
