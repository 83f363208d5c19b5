"""Crossing robots: two robots swapping places and four crossing the centre, on the world model, against driving alone.

    zenav bench planning   # with the planner's tables (bench/planning.py)

Each robot runs the navigator's goal machine among the others (traffic_machine.py: right of way by id, lanes, slowing,
waiting, detours round robots; each robot's body telling the next points of its way, as its motor's does) and the
motor's guard under its commands, on its own world-model robot (the default scenario's motor lag, slip and wheel
errors; the pose the truth), the robots' bodies kept out of each other by the sim's contacts, which are counted. On an
open 3 m field. Each run perturbs the starts and goals (up to PERTURB in x and y), the
start headings (up to TURN off facing the goal) and seeds the world anew. Each robot's goal is also driven alone
from the same start, on the same seed: a run's time is when its last robot arrived, against the longest of them alone.
"""

from __future__ import annotations

import math
import statistics
from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from zenav.bench.studies.harness import Trial
from zenav.common.config import Field, RobotConfig
from zenav.common.contract import GoalResult
from zenav.common.contract import State as NavCode
from zenav.common.field import Point
from zenav.common.scenarios import PRESETS
from zenav.services.motor.guard import Guard
from zenav.services.navigator.controllers import PoseSample, Wheelbase
from zenav.services.navigator.goals import Goal
from zenav.services.navigator.params import Params
from zenav.services.navigator.planner import Planner
from zenav.services.navigator.traffic import Other, Traffic
from zenav.services.navigator.traffic_machine import COUNTERS, TrafficMachine
from zenav.world.bodies import Disc
from zenav.world.robot import State

AREA = Field(x_min=0.0, x_max=3.0, y_min=0.0, y_max=3.0)  # [m] open
CENTRE, ARM = (1.5, 1.5), 1.0  # [m] the robots start ARM from the centre, their goals opposite
PERTURB = 0.05  # [m] starts and goals moved by up to this in x and y
TURN = 0.2  # [rad] start headings off facing the goal by up to this
TIMEOUT = 90.0  # [s] a run not over by then fails
RADIUS = 0.1  # [m] each robot's footprint ([robot] radius, [sim] body_radius)
GUARD_GAP, GUARD_DECEL = 0.005, 0.5  # [m], [m/s^2] the motor's guard, as configured by default
CASES = {
    "2 swapping": ((-1.0, 0.0), (1.0, 0.0)),
    "4 crossing the centre": ((0.0, 1.0), (1.0, 0.0), (0.0, -1.0), (-1.0, 0.0)),
}


@dataclass
class Crossing:
    """One case's runs."""

    name: str
    robots: int
    runs: int = 0
    succeeded: int = 0  # runs where every robot reached its goal
    contact_runs: int = 0  # runs with a contact between robots
    least: float = math.inf  # [m] the least gap between two footprints over every run
    ratios: list[float] = field(default_factory=list)  # the run's time / the longest alone
    counts: Counter[str] = field(default_factory=Counter)  # the machines' traffic counters, summed over the runs
    failures: list[str] = field(default_factory=list)


@dataclass
class Robotrun:
    """One robot of a run: its world, its machine, its goal."""

    name: str
    trial: Trial
    machine: TrafficMachine
    goal: Goal
    done: str = ""  # its result once ended
    t_end: float = math.inf  # [s]


def setup(case: str, run: int, seed: int) -> list[tuple[str, Point, Point, float]]:
    """(name, start, goal, start heading) of each robot of a run, perturbed (seeded)."""
    rng = np.random.default_rng([seed, run, 0x43524F53])
    out = []
    for i, (ux, uy) in enumerate(CASES[case]):
        a = (CENTRE[0] + ux * ARM + rng.uniform(-PERTURB, PERTURB), CENTRE[1] + uy * ARM + rng.uniform(-PERTURB, PERTURB))
        b = (CENTRE[0] - ux * ARM + rng.uniform(-PERTURB, PERTURB), CENTRE[1] - uy * ARM + rng.uniform(-PERTURB, PERTURB))
        heading = math.atan2(b[1] - a[1], b[0] - a[0]) + rng.uniform(-TURN, TURN)
        out.append((f"r{i + 1}", (float(a[0]), float(a[1])), (float(b[0]), float(b[1])), float(heading)))
    return out


def simulate(robots: list[tuple[str, Point, Point, float]], seed: int, params: Params) -> tuple[list[Robotrun], float, int]:
    """The robots driven together to their goals: each robot's run, the least gap between footprints [m], contacts."""
    scenario = PRESETS["default"]
    robot = RobotConfig(ticks_per_rev=scenario.ticks_per_rev, radius=RADIUS)
    wheels = Wheelbase(robot.track_width, robot.wheel_radius, robot.max_wheel_speed)
    guard = Guard((), RADIUS, GUARD_GAP, GUARD_DECEL)
    edges = Planner(AREA, RADIUS + AREA.margin)  # the open field: detours keep inside its edges
    runs = []
    for i, (name, a, b, heading) in enumerate(robots):
        trial = Trial(robot, scenario, seed * 100 + i, camera=False, x=a[0], y=a[1], theta=heading, others={})
        machine = TrafficMachine(params, wheels, AREA, traffic=Traffic(name, RADIUS, AREA.margin, edges))
        goal = Goal(NavCode.MOVING_TO_POINT, points=(b,), speed=params.speed, tolerance=params.tolerance)
        runs.append(Robotrun(name, trial, machine, goal))
    for r in runs:
        r.machine.on_pose(_pose(r.trial))
        r.machine.start(r.goal, 0.0)
    least, contacts = math.inf, 0
    every = max(1, round(params.check_period / runs[0].trial.dt))
    for step in range(round(TIMEOUT * runs[0].trial.rate)):
        if all(r.done for r in runs):
            break
        bodies = {r.name: r.trial.bot.state for r in runs}
        ways = {r.name: r.machine.way() for r in runs}
        cmds = []
        for r in runs:
            others = [_other(n, s, ways[n]) for n, s in bodies.items() if n != r.name]
            cmds.append(_command(r, others, guard, step, every))
        for r, (left, right) in zip(runs, cmds):
            r.trial.others = {n: Disc(s.x, s.y, RADIUS) for n, s in bodies.items() if n != r.name}
            r.trial.step(left, right)
            contacts += bool(r.trial.bot.met)
        states = [r.trial.bot.state for r in runs]
        for i, s in enumerate(states):
            for o in states[i + 1 :]:
                least = min(least, math.hypot(s.x - o.x, s.y - o.y) - 2.0 * RADIUS)
    return runs, least, contacts


def _other(name: str, s: State, way: tuple[Point, ...] = ()) -> Other:
    return Other(name, s.x, s.y, RADIUS, s.v * math.cos(s.theta), s.v * math.sin(s.theta), way)


def _pose(trial: Trial) -> PoseSample:
    s = trial.bot.state
    return PoseSample(trial.t, s.x, s.y, s.theta, s.v, s.omega, 0.0, 0.0)


def _command(r: Robotrun, others: list[Other], guard: Guard, step: int, every: int) -> tuple[float, float]:
    """The wheel commands of one robot for this step: its machine's, through the guard."""
    if r.done:
        return 0.0, 0.0
    pose = _pose(r.trial)
    cmd, end = r.machine.drive(pose, others)
    if end is None and step % every == 0:
        end = r.machine.check(pose.t)
    if end is not None:
        r.done, r.t_end = end.result + (f": {end.message}" if end.result != GoalResult.SUCCEEDED else ""), pose.t
        return 0.0, 0.0
    v, omega = cmd or (0.0, 0.0)
    lim = guard.limit(v, omega, pose.x, pose.y, pose.theta, [(o.name, (o.x, o.y, o.radius)) for o in others])
    return r.trial.bot.wheels(lim.v, lim.omega)


def measure(case: str, runs: int, seed: int, params: Params | None = None) -> Crossing:
    """`runs` perturbed runs of a case, each against its robots driven alone."""
    params = params or Params()
    res = Crossing(case, len(CASES[case]))
    for k in range(runs):
        robots = setup(case, k, seed)
        together, least, contacts = simulate(robots, seed * 1000 + k, params)
        alone = [simulate([rb], seed * 1000 + k, params)[0][0].t_end for rb in robots]
        res.runs += 1
        ok = all(r.done == GoalResult.SUCCEEDED for r in together)
        res.succeeded += ok
        res.contact_runs += contacts > 0
        res.least = min(res.least, least)
        for r in together:
            res.counts.update(r.machine.counts)
        if ok:
            res.ratios.append(max(r.t_end for r in together) / max(alone))
        else:
            res.failures += [f"{case} run {k}: {r.name} {r.done or 'timeout'}" for r in together if r.done != GoalResult.SUCCEEDED]
    return res


def tables(cases: list[Crossing]) -> list[str]:
    """The crossing table's markdown."""
    lines = [
        f"Crossing robots: each run's starts and goals perturbed by up to {PERTURB} m and its headings by up to {TURN} rad "
        f"(seeded), on the world model (default scenario, the pose the truth), footprints {RADIUS} m, the guard under "
        "every command; time: the last robot's arrival against the longest of the same goals driven alone.",
        "",
        "| case | runs | every robot arrived | runs with a contact | least gap between footprints [m] "
        "| time / alone: mean, max | per run: detours, waits, slowdowns, steps aside |",
        "|---|---|---|---|---|---|---|",
    ]
    for c in cases:
        mean = statistics.fmean(c.ratios) if c.ratios else math.nan
        lines.append(
            f"| {c.name} | {c.runs} | {c.succeeded} | {c.contact_runs} | {c.least:.3f} "
            f"| {mean:.2f}, {max(c.ratios, default=math.nan):.2f} | {', '.join(per(c, n) for n in COUNTERS)} |"
        )
    for c in cases:
        lines += [f"- {f}" for f in c.failures[:10]]
    return lines


def per(c: Crossing, name: str) -> str:
    """A traffic counter per run, as text."""
    return f"{c.counts[name] / max(c.runs, 1):.1f}"


def report(runs: int = 50, seed: int = 1) -> list[str]:
    """Both cases: the table's markdown."""
    return tables([measure(case, runs, seed) for case in CASES])
