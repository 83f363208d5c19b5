"""From a goal request to a Goal and its nav/state map: defaults taken, speeds clamped, limits checked.

Pure: the config and, for turn_to_point, the pose come in as arguments. A request
that cannot be driven raises `Invalid`, naming the field (an invalid_argument reply).
"""

from __future__ import annotations

import math
from typing import Any, TypedDict, cast

from zenav.common import messages as m
from zenav.common.contract import State
from zenav.common.geometry import wrap_angle
from zenav.common.goalschema import SLOWEST
from zenav.services.navigator.controllers import PoseSample, check_polar_gains
from zenav.services.navigator.goals import Goal
from zenav.services.navigator.params import Params

Resolved = tuple[Goal, dict[str, Any]]  # the goal, and its `goal` map of nav/state


class Invalid(ValueError):
    """A request that cannot be driven, whatever the robot's state; the message names the field."""


def _speed(speed: float | None, cfg: Params) -> float:
    """The forward speed [m/s] of a goal, clamped to the limit."""
    return min(_slowest(speed or cfg.speed, "m/s"), cfg.max_speed)


def _slowest(speed: float, unit: str) -> float:
    """`speed` if it is goalschema.SLOWEST or more (its magnitude, signed for move_straight), else Invalid naming the bound."""
    if abs(speed) < SLOWEST:
        raise Invalid(f"speed: {speed:g} {unit} is under the slowest a goal drives, {SLOWEST:g} {unit}")
    return speed


def _timeout(req: m.GoalOptions, cfg: Params) -> float:
    """[s] the goal's time-out (0: none)."""
    return req.timeout or cfg.goal_timeout


class Chain(TypedDict, total=False):
    """A chained goal's fields (none for a goal that stops)."""

    min_speed: float
    early_exit_range: float


def _chain(req: m.GoalOptions, speed: float) -> Chain:
    """A chained move's `min_speed` (at most the goal's speed) and `early_exit_range`; {} for a move that stops."""
    if not req.min_speed:
        if req.early_exit_range:
            raise Invalid("early_exit_range: only a chained move (min_speed > 0) exits early; a move that stops ends at its tolerance")
        return Chain()
    return Chain(min_speed=min(req.min_speed, speed), early_exit_range=req.early_exit_range or 0.0)


def move_to_point(req: m.MoveToPoint, cfg: Params) -> Resolved:
    """Drive to (x, y)."""
    speed, tol = _speed(req.speed, cfg), req.tolerance or cfg.tolerance
    chain, backwards, timeout = _chain(req, speed), not req.forwards, _timeout(req, cfg)
    goal = Goal(State.MOVING_TO_POINT, ((req.x, req.y),), speed=speed, tolerance=tol, timeout=timeout, backwards=backwards, **chain)
    return goal, {"type": "move_to_point", "x": req.x, "y": req.y, "speed": speed, "tolerance": tol, "forwards": req.forwards, **chain}


def move_to_pose(req: m.MoveToPose, cfg: Params) -> Resolved:
    """Drive to (x, y) and arrive with heading theta: the polar tracker or the boomerang, then a turn in place."""
    if cfg.pose_controller == "polar":
        try:
            check_polar_gains(cfg.k_rho, cfg.k_alpha, cfg.k_beta)
        except ValueError as e:
            raise Invalid(f"[navigator] pose_controller = polar: {e}") from None
    speed, tol = _speed(req.speed, cfg), req.tolerance or cfg.tolerance
    heading, heading_tol = wrap_angle(req.theta), req.heading_tolerance or cfg.heading_tolerance
    lead, chain = cfg.lead if req.lead is None else req.lead, _chain(req, speed)
    goal = Goal(
        State.MOVING_TO_POSE,
        points=((req.x, req.y),),
        heading=heading,
        speed=speed,
        tolerance=tol,
        heading_tolerance=heading_tol,
        lead=lead,
        timeout=_timeout(req, cfg),
        backwards=not req.forwards,
        **chain,
    )
    info = {"type": "move_to_pose", "x": req.x, "y": req.y, "theta": heading, "speed": speed, "tolerance": tol}
    info |= {"heading_tolerance": heading_tol, "controller": cfg.pose_controller, "lead": lead, "forwards": req.forwards}
    return goal, info | chain


def turn_to_heading(req: m.TurnToHeading, cfg: Params) -> Resolved:
    """Turn in place to a heading."""
    return _turn(wrap_angle(req.heading), req, cfg, {"type": "turn_to_heading", "heading": req.heading})


def turn_to_point(req: m.TurnToPoint, cfg: Params, pose: PoseSample) -> Resolved:
    """Turn in place to face (x, y), or to turn the back to it, the heading fixed from the pose at the start (as Botball's turnToPoint)."""
    if math.hypot(req.x - pose.x, req.y - pose.y) < 1e-3:
        raise Invalid("x, y: the point is where the robot is, it has no heading")
    heading = math.atan2(req.y - pose.y, req.x - pose.x)
    if not req.forwards:
        heading = wrap_angle(heading + math.pi)
    return _turn(heading, req, cfg, {"type": "turn_to_point", "x": req.x, "y": req.y, "heading": heading, "forwards": req.forwards})


def swing_to_heading(req: m.SwingToHeading, cfg: Params) -> Resolved:
    """Turn to a heading about one wheel, which stays still (LemLib's swingToHeading, EZ-Template's swing turns)."""
    info = {"type": "swing_to_heading", "heading": req.heading, "side": req.side}
    return _turn(wrap_angle(req.heading), req, cfg, info, pivot=PIVOTS[req.side])


def move_straight(req: m.MoveStraight, cfg: Params) -> Resolved:
    """Drive on the start heading; stop after `distance` if given (else after straight_max_time)."""
    if req.speed == 0.0:
        raise Invalid("speed: must not be 0 (use nav/stop to stop)")
    speed = math.copysign(min(abs(_slowest(req.speed, "m/s")), cfg.max_speed), req.speed)
    goal = Goal(State.MOVING_STRAIGHT, speed=speed, distance=req.distance, tolerance=cfg.tolerance)
    return goal, {"type": "move_straight", "speed": speed, "distance": req.distance}


def follow_path(req: m.FollowPath, cfg: Params) -> Resolved:
    """Drive through the points in order without stopping, each within its tolerance ([x, y, tolerance]).

    A point without one: the last takes `tolerance`, the others `waypoint_tolerance`.
    """
    pts = req.points
    if len(pts) > cfg.max_path_points:
        raise Invalid(f"points: {len(pts)} is over [navigator] max_path_points = {cfg.max_path_points}")
    speed, tol = _speed(req.speed, cfg), req.tolerance or cfg.tolerance
    through, chain = req.waypoint_tolerance or cfg.waypoint_tolerance, _chain(req, speed)
    if max(map(len, pts)) == 2:  # no point names its tolerance: no loop in Python (a stop may wait on this)
        points, tols = cast(tuple[tuple[float, float], ...], tuple(pts)), (through,) * (len(pts) - 1) + (tol,)
    else:
        bad = next((i for i, p in enumerate(pts) if len(p) == 3 and p[2] <= 0.0), None)
        if bad is not None:
            raise Invalid(f"points[{bad}]: the tolerance (third value) must be > 0")
        points = tuple((p[0], p[1]) for p in pts)
        tols = tuple(p[2] if len(p) == 3 else through for p in pts[:-1]) + (pts[-1][2] if len(pts[-1]) == 3 else tol,)
    goal = Goal(
        State.FOLLOWING_PATH,
        points=points,
        speed=speed,
        tolerance=tols[-1],
        point_tolerances=tols,
        timeout=_timeout(req, cfg),
        backwards=not req.forwards,
        **chain,
    )
    info = {"type": "follow_path", "points": req.points, "speed": speed, "tolerance": tols[-1], "waypoint_tolerance": through}
    return goal, info | {"forwards": req.forwards} | chain


TURN_WAYS = {"auto": 0, "ccw": 1, "cw": -1}  # a turn request's direction -> the sign of its turn rate
PIVOTS = {"left": 1, "right": -1}  # a swing's locked side -> Goal.pivot


def _turn(
    heading: float, req: m.TurnToHeading | m.TurnToPoint | m.SwingToHeading, cfg: Params, info: dict[str, Any], pivot: int = 0
) -> Resolved:
    """A turn in place (`pivot` 0), or a swing about one wheel (Goal.pivot)."""
    speed = min(_slowest(req.speed or cfg.turn_speed, "rad/s"), cfg.max_turn_speed)
    tol, chain, way = req.tolerance or cfg.heading_tolerance, _chain(req, speed), TURN_WAYS[req.direction]
    timeout = _timeout(req, cfg)
    goal = Goal(State.TURNING_TO_HEADING, heading=heading, speed=speed, tolerance=tol, timeout=timeout, direction=way, pivot=pivot, **chain)
    return goal, {**info, "speed": speed, "tolerance": tol, "direction": req.direction, **chain}
