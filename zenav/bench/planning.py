"""The planning section: the planner on three layouts, and goals planned round obstacles driven on the world model.

    zenav bench planning

Layouts: the shipped `table` and `arena`, and `random20` (20 seeded boxes and discs on a 3 m square). Per layout,
random start/goal pairs whose both ends keep the clearance ([robot] radius + [field] margin) from every obstacle
and which a reference planner reaches (the same visibility graph on a much finer approximation of the rounded
corners: 128 sides a circle, within 0.03 % of the true shortest way): the planner's success, its way's length against
the reference's, the least clearance of its way (exact, against the obstacles as given), and its time per plan (the
field's graph built once, as the navigator does). Then `drives` pairs per layout are driven as move_to_point goals by
the navigator's goal machine on the world model's robot (the default scenario's motor lag, slip and wheel errors,
the pose the truth), its body kept out of the obstacles by the sim's contacts: result, contacts, the robot's least
true clearance, time.
"""

from __future__ import annotations

import math
import statistics
import time
from dataclasses import dataclass, field

import numpy as np

from zenav.bench.studies.harness import Trial
from zenav.bench.studies.navigator import PoseError, drive
from zenav.common.config import Field, Obstacle, RobotConfig, Settings
from zenav.common.contract import GoalResult, State
from zenav.common.field import FieldError, Point, Shape, check_layout, circle_shape, polygon_shape
from zenav.common.scenarios import PRESETS
from zenav.services.navigator.controllers import Wheelbase
from zenav.services.navigator.goals import Goal, GoalMachine
from zenav.services.navigator.params import Params
from zenav.services.navigator.planner import NoPath, Planner, clearance, length
from zenav.services.navigator.routing import route

LAYOUTS = ("table", "arena", "random20")
REFERENCE_SIDES = 128  # sides of the reference planner's circles
RADIUS, MARGIN = RobotConfig().radius, Field().margin  # [m] the defaults
DRAW_LIMIT = 200  # draws per pair at most (a crowded layout rejects many)


@dataclass
class Layout:
    """One layout's planner figures."""

    name: str
    obstacles: int
    build_ms: float  # [ms] the field's graph, once
    pairs: int = 0  # reachable pairs tried
    failed: int = 0  # reachable pairs the planner found no way for
    ratios: list[float] = field(default_factory=list)  # length / the reference's
    clearances: list[float] = field(default_factory=list)  # [m] least clearance of each way
    times: list[float] = field(default_factory=list)  # [ms] per plan
    detoured: int = 0  # pairs whose straight way was blocked


@dataclass
class Drives:
    """One layout's goals driven on the world model."""

    name: str
    goals: int = 0
    succeeded: int = 0
    contacts: int = 0
    clearances: list[float] = field(default_factory=list)  # [m] the robot's least true clearance over each goal
    durations: list[float] = field(default_factory=list)  # [s]
    failures: list[str] = field(default_factory=list)


def random_field(n: int, seed: int) -> Field:
    """`n` seeded boxes and discs on a 3 m square, none overlapping another."""
    rng = np.random.default_rng([seed, 0x504C414E])
    obstacles: list[Obstacle] = []
    shapes: list[Shape] = []
    while len(obstacles) < n:
        x, y = rng.uniform(0.0, 3.0, 2)
        w, h = rng.uniform(0.05, 0.3, 2)
        if rng.random() < 0.4:
            o = Obstacle(name=f"disc {len(obstacles)}", circle=(float(x), float(y), float(w / 2)))
            s = circle_shape(o.name, o.circle or ())
        else:
            a = rng.uniform(0.0, math.pi)
            c, d = math.cos(a), math.sin(a)
            corners = [(x + c * u - d * v, y + d * u + c * v) for u, v in ((-w, -h), (w, -h), (w, h), (-w, h))]
            pts = tuple((float(px), float(py)) for px, py in corners)
            o = Obstacle(name=f"box {len(obstacles)}", polygon=pts)
            s = polygon_shape(o.name, pts)
        if any(_overlap(s, t) for t in shapes):
            continue
        obstacles.append(o)
        shapes.append(s)
    return Field(x_min=-0.2, x_max=3.2, y_min=-0.2, y_max=3.2, obstacles=tuple(obstacles))


def _overlap(a: Shape, b: Shape) -> bool:
    ax0, ay0, ax1, ay1 = a.bounds()
    bx0, by0, bx1, by1 = b.bounds()
    return not (ax1 + 0.05 < bx0 or bx1 + 0.05 < ax0 or ay1 + 0.05 < by0 or by1 + 0.05 < ay0)


def layout(name: str, seed: int) -> Field:
    """A layout by name."""
    if name == "random20":
        area = random_field(20, seed)
        try:
            check_layout(area.shapes(), (area.x_min, area.y_min, area.x_max, area.y_max))
        except FieldError as e:  # not expected: the draw keeps them apart
            raise SystemExit(f"random20: {e}") from None
        return area
    return Settings.load(None, field={"file": name}).field


def _clear_point(area: Field, planner: Planner, rng: np.random.Generator) -> tuple[float, float] | None:
    c = planner.clearance
    for _ in range(DRAW_LIMIT):
        p = (float(rng.uniform(area.x_min + c, area.x_max - c)), float(rng.uniform(area.y_min + c, area.y_max - c)))
        if all(s.clearance(*p) >= c for s in planner.shapes):
            return p
    return None


Pair = tuple[Point, Point, list[Point]]  # start, goal, the reference's way


def pairs(area: Field, n: int, seed: int, reference: Planner) -> list[Pair]:
    """`n` seeded pairs with both ends clear that the reference reaches, with the reference's way."""
    rng = np.random.default_rng([seed, 0x50414952])
    out: list[Pair] = []
    for _ in range(n * 5):
        if len(out) == n:
            break
        a, b = _clear_point(area, reference, rng), _clear_point(area, reference, rng)
        if a is None or b is None or math.dist(a, b) < 0.2:
            continue
        try:
            out.append((a, b, reference.plan(a, b)))
        except NoPath:
            continue
    return out


def measure(name: str, n: int, seed: int) -> Layout:
    """The planner on one layout: `n` reachable pairs."""
    area = layout(name, seed)
    t0 = time.perf_counter()
    planner = Planner(area, RADIUS + MARGIN)
    res = Layout(name, len(area.obstacles), (time.perf_counter() - t0) * 1000.0)
    reference = Planner(area, RADIUS + MARGIN, arc_sides=REFERENCE_SIDES)
    for a, b, ref in pairs(area, n, seed, reference):
        res.pairs += 1
        t0 = time.perf_counter()
        try:
            way = planner.plan(a, b)
        except NoPath:
            res.failed += 1
            continue
        res.times.append((time.perf_counter() - t0) * 1000.0)
        res.detoured += len(way) > 1
        res.ratios.append(length(a, way) / length(a, ref))
        res.clearances.append(clearance(planner.shapes, a, way))
    return res


def driven(name: str, n: int, seed: int) -> Drives:
    """`n` pairs whose straight way is blocked, driven as planned move_to_point goals on the world model."""
    area = layout(name, seed)
    planner = Planner(area, RADIUS + MARGIN)
    params = Params()
    res = Drives(name)
    scenario = PRESETS["default"]
    robot = RobotConfig(ticks_per_rev=scenario.ticks_per_rev)
    for i, (a, b, _) in enumerate(p for p in pairs(area, n * 4, seed + 1, planner) if len(p[2]) > 1):
        if res.goals == n:
            break
        trial = Watched(robot, scenario, seed * 1000 + i, camera=False, x=a[0], y=a[1], theta=math.atan2(b[1] - a[1], b[0] - a[0]))
        trial.watch(planner.shapes)
        goal = route(Goal(State.MOVING_TO_POINT, points=(b,), speed=params.speed, tolerance=params.tolerance), a, RADIUS, planner, 0.01)
        machine = GoalMachine(params, Wheelbase(robot.track_width, robot.wheel_radius, robot.max_wheel_speed), area)
        out = drive(trial, machine, goal, PoseError(0.0, scenario.vps_rate_hz, seed))
        res.goals += 1
        res.succeeded += out.result == GoalResult.SUCCEEDED
        res.contacts += trial.contacts > 0
        res.clearances.append(trial.least)
        res.durations.append(out.duration)
        if out.result != GoalResult.SUCCEEDED:
            res.failures.append(f"{name} ({a[0]:.2f}, {a[1]:.2f}) -> ({b[0]:.2f}, {b[1]:.2f}): {out.result} {out.message}")
    return res


class Watched(Trial):
    """A trial whose robot's body keeps out of the obstacles, its least clearance and its contacts followed."""

    def watch(self, shapes: tuple[Shape, ...]) -> None:
        self.bot.obstacles = self.shapes = shapes
        self.least, self.contacts = math.inf, 0  # [m], steps held by an obstacle

    def step(self, left: float, right: float) -> None:
        super().step(left, right)
        s = self.bot.state
        self.least = min(self.least, min(sh.clearance(s.x, s.y) for sh in self.shapes))
        self.contacts += bool(self.bot.met)


def _p(values: list[float], q: float) -> float:
    return float(np.percentile(values, q)) if values else math.nan


def tables(layouts: list[Layout], drives: list[Drives]) -> list[str]:
    """The section's markdown."""
    need = RADIUS + MARGIN
    lines = [
        f"Planner: random reachable start/goal pairs per layout, clearance {need:.2f} m ([robot] radius {RADIUS} + [field] margin "
        f"{MARGIN}); length against the reference planner's (circles of {REFERENCE_SIDES} sides); clearance exact, "
        "against the obstacles as given; time per plan, the field's graph built once.",
        "",
        "| layout | obstacles | graph built [ms] | pairs (blocked straight) | found | length / shortest: mean, max "
        "| least clearance [m] | plan time p50 / p95 / max [ms] |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in layouts:
        lines.append(
            f"| {r.name} | {r.obstacles} | {r.build_ms:.0f} | {r.pairs} ({r.detoured}) | {r.pairs - r.failed} "
            f"| {statistics.fmean(r.ratios):.4f}, {max(r.ratios):.4f} | {min(r.clearances):.4f} "
            f"| {_p(r.times, 50):.2f} / {_p(r.times, 95):.2f} / {max(r.times):.2f} |"
        )
    lines += [
        "",
        "Driven: pairs whose straight way is blocked, as move_to_point goals planned round the obstacles, on the world "
        "model (default scenario, the pose the truth), the sim counting contacts.",
        "",
        "| layout | goals | succeeded | goals with a contact | robot's least true clearance [m] | time mean / max [s] |",
        "|---|---|---|---|---|---|",
    ]
    for d in drives:
        lines.append(
            f"| {d.name} | {d.goals} | {d.succeeded} | {d.contacts} | {min(d.clearances, default=math.nan):.4f} "
            f"| {statistics.fmean(d.durations) if d.durations else math.nan:.1f} / {max(d.durations, default=math.nan):.1f} |"
        )
    for d in drives:
        lines += [f"- {f}" for f in d.failures]
    return lines


def report(pairs_per_layout: int = 200, drives: int = 20, seed: int = 1) -> list[str]:
    """Every layout measured and driven: the section's markdown."""
    return tables([measure(n, pairs_per_layout, seed) for n in LAYOUTS], [driven(n, drives, seed) for n in LAYOUTS])
