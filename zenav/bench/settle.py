"""The settle table: how every kind of move ends, against the truth, over seeded trials.

`zenav bench settle` writes two: with the synthetic late VPS's pose error (the
default here) and with the camera VPS's (CAMERA_SIGMA, CAMERA_HEADING_SIGMA).

Each move runs the navigator's goal machine on the world model's robot through the
navigator study's harness (bench/studies: motor lag, deadband, slip, encoders), fed
the late VPS pose error model (PoseError: the truth plus an error that jumps at the
VPS rate). Per move: final position and heading error against the truth (p50 / p95 /
max), time to the end, the exits, the results, and the arrival heading swing (the
largest true heading change over the last 5 cm travelled; for a pose, that includes its
final turn in place to the heading).
"""

from __future__ import annotations

import dataclasses
import math
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass

import msgspec
import numpy as np

from zenav.bench.studies.harness import Trial
from zenav.bench.studies.navigator import HEADING_ARM, SETTLE, TIMEOUT, GoalDriver, PoseError
from zenav.common.config import RobotConfig
from zenav.common.contract import GoalResult, State
from zenav.common.geometry import wrap_angle
from zenav.common.scenarios import PATH, PRESETS, SQUARE, Scenario
from zenav.services.navigator.controllers import Wheelbase
from zenav.services.navigator.goals import Goal, GoalMachine
from zenav.services.navigator.params import POSE_CONTROLLERS, Params

SWING_WINDOW = 0.05  # [m] the arrival heading swing is measured over this last stretch travelled
LATE_VPS_SIGMA = 0.005  # [m] 1 sigma of the late VPS pose error (the navigator study's middle condition)
# The fused pose's error with the overhead camera as the VPS (docs/bench/report.md: RMSE 0.03 cm, 0.06 to 0.10 deg).
CAMERA_SIGMA = 0.0002  # [m] per axis
CAMERA_HEADING_SIGMA = math.radians(0.1)  # [rad]


@dataclass(frozen=True)
class Move:
    """One row of the table: a goal from (0, 0, 0), with config overrides."""

    name: str
    goal: Goal
    overrides: tuple[tuple[str, object], ...] = ()


def moves(p: Params) -> list[Move]:
    """The move types, short and long, at the default tolerances; the path trial at its own 5 cm waypoint tolerance."""
    deg = math.radians

    def point(x: float, y: float) -> Goal:
        return Goal(State.MOVING_TO_POINT, points=((x, y),), speed=p.speed, tolerance=p.tolerance)

    def pose(x: float, y: float, theta: float) -> Goal:
        return Goal(State.MOVING_TO_POSE, ((x, y),), theta, p.speed, p.tolerance, heading_tolerance=p.heading_tolerance, lead=p.lead)

    def turn(theta: float) -> Goal:
        return Goal(State.TURNING_TO_HEADING, heading=theta, speed=p.turn_speed, tolerance=p.heading_tolerance)

    def path(points: tuple[tuple[float, float], ...], tol: float, speed: float) -> Goal:
        return Goal(State.FOLLOWING_PATH, points=points, speed=speed, tolerance=tol)

    five_cm = path(PATH, 0.05, p.max_speed)
    other = next(c for c in POSE_CONTROLLERS if c != p.pose_controller)
    return [
        Move("point 0.3 m", point(0.3, 0.0)),
        Move("point 1.5 m", point(1.5, 0.0)),
        Move("point 1.5 m backwards", dataclasses.replace(point(-1.5, 0.0), backwards=True)),
        Move(f"pose 0.4 m, 90 deg, {p.pose_controller}", pose(0.3, 0.3, deg(90))),
        Move(f"pose 1.3 m, 90 deg, {p.pose_controller}", pose(1.2, 0.6, deg(90))),
        Move(f"pose 1.3 m, 90 deg, {other}", pose(1.2, 0.6, deg(90)), (("pose_controller", other),)),
        Move("turn 30 deg", turn(deg(30))),
        Move("turn 170 deg", turn(deg(170))),
        Move("path (1,0) (1,1)", path(PATH, p.tolerance, p.speed)),
        Move("path square 4 m", path(SQUARE, p.tolerance, p.speed)),
        Move(f"path (1,0) (1,1), 5 cm waypoints, {p.max_speed:g} m/s", five_cm, (("waypoint_tolerance", 0.05),)),
    ]


@dataclass(frozen=True)
class Outcome:
    """One move driven to its end and left to rest."""

    result: str
    exit: str
    position: float  # [m] true final position error (0 for turns)
    heading: float  # [rad] true final heading error (turns, poses; else nan)
    duration: float  # [s] start to the end of the goal
    swing: float  # [rad] largest true heading change over the last SWING_WINDOW travelled (nan for turns)


def run(move: Move, params: Params, scenario: Scenario, seed: int, sigma: float, heading_sigma: float | None = None) -> Outcome:
    """Drive one move on a fresh trial; measure it against the truth."""
    cfg = msgspec.structs.replace(params, **dict(move.overrides))
    trial = Trial(RobotConfig(ticks_per_rev=scenario.ticks_per_rev), scenario, seed, camera=False)
    r = trial.bot.robot
    machine = GoalMachine(cfg, Wheelbase(r.track_width, r.wheel_radius, r.max_wheel_speed))
    driver = GoalDriver(machine, move.goal, PoseError(sigma, scenario.vps_rate_hz, seed, heading_sigma), trial)
    first = len(trial.streams.truth) - 1
    trial.run(driver, TIMEOUT)
    duration = trial.t - driver.t0
    trial.run(lambda tr: (0.0, 0.0), SETTLE)
    truth = trial.streams.truth[first:]
    end, s, goal = driver.end, trial.bot.state, move.goal
    if goal.state == State.TURNING_TO_HEADING:
        position, swing = 0.0, math.nan
    else:
        position = math.dist((s.x, s.y), goal.points[-1])
        swing = _swing(truth)
    angular = goal.state in (State.TURNING_TO_HEADING, State.MOVING_TO_POSE)
    heading = abs(wrap_angle(goal.heading - s.theta)) if angular else math.nan
    result, exit = (end.result, end.exit) if end else ("timeout", "none")
    return Outcome(result, exit, position, heading, duration, swing)


def _swing(truth: Sequence[object]) -> float:
    """[rad] the largest heading change over the last SWING_WINDOW [m] travelled."""
    xy = np.array([(t.x, t.y) for t in truth])  # type: ignore[attr-defined]
    theta = np.unwrap([t.theta for t in truth])  # type: ignore[attr-defined]
    travel = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))))
    last = theta[travel >= travel[-1] - SWING_WINDOW]
    return float(np.max(np.abs(last - last[0])))


def _stats(values: Sequence[float], scale: float, digits: int = 2) -> str:
    v = np.array([x for x in values if not math.isnan(x)]) * scale
    if v.size == 0:
        return "-"
    p50, p95 = np.percentile(v, [50, 95])
    return f"{p50:.{digits}f} / {p95:.{digits}f} / {v.max():.{digits}f}"


def table(
    trials: int, sigma: float = LATE_VPS_SIGMA, params: Params | None = None, scenario: str = "default", heading_sigma: float | None = None
) -> str:
    """The settle table (markdown), `trials` seeds per move; `heading_sigma` [rad] None: sigma seen over HEADING_ARM."""
    p, sc = params or Params(), PRESETS[scenario]
    heading = sigma / HEADING_ARM if heading_sigma is None else heading_sigma
    lines = [
        f"Settle table: {trials} seeded trials per move, `{scenario}` scenario, late VPS pose error {sigma * 100:g} cm "
        f"(1 sigma; heading {math.degrees(heading):.2f} deg), default tolerances {p.tolerance * 100:g} cm / "
        f"{math.degrees(p.heading_tolerance):.2f} deg; errors are true final pose to goal",
        "",
        "| move | position error p50 / p95 / max [cm] | heading error p50 / p95 / max [deg] | time p50 / p95 / max [s] "
        "| arrival swing p50 / p95 / max [deg] | succeeded | exits |",
        "|---|---|---|---|---|---|---|",
    ]
    for move in moves(p):
        out = [run(move, p, sc, seed, sigma, heading) for seed in range(trials)]
        pos = _stats([o.position for o in out], 100.0) if move.goal.state != State.TURNING_TO_HEADING else "-"
        exits = ", ".join(f"{k} {n}" for k, n in Counter(o.exit for o in out).most_common())
        lines.append(
            f"| {move.name} | {pos} | {_stats([o.heading for o in out], 180 / math.pi)} | {_stats([o.duration for o in out], 1.0)} "
            f"| {_stats([o.swing for o in out], 180 / math.pi)} | {sum(o.result == GoalResult.SUCCEEDED for o in out)}/{trials} | {exits} |"
        )
    return "\n".join(lines)
