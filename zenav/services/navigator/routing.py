"""A goal's way round the field's obstacles: targets checked against them, blocked legs replaced by the planner's detours.

Pure: the planner, the start and the footprint come in as arguments. A target (a path's point) closer to an obstacle
than the robot's clearance (footprint radius plus margin) is refused naming the obstacle; so is a start where the
robot's footprint overlaps one. Each leg between the start and the targets whose straight way is blocked is planned
around; the user's points keep their tolerances, the detour's corners take `corner_tolerance` (small: a corner
passed early cuts towards the obstacle by up to that much, which the margin must hold).
"""

from __future__ import annotations

from dataclasses import replace

from zenav.common.contract import State
from zenav.common.field import Point
from zenav.services.navigator.goals import Goal
from zenav.services.navigator.planner import NoPath, Planner

PLANNED = (State.MOVING_TO_POINT, State.MOVING_TO_POSE, State.FOLLOWING_PATH)  # the goals whose points are planned between


class Blocked(ValueError):
    """A goal that cannot be driven among the obstacles; the message names the point and the obstacle."""


def check_targets(goal: Goal, planner: Planner) -> None:
    """Blocked if a target lies within the clearance of an obstacle."""
    for i, (x, y) in enumerate(goal.points):
        for s in planner.shapes:
            gap = s.clearance(x, y)
            if gap < planner.clearance:
                where = f"points[{i}]" if goal.state == State.FOLLOWING_PATH else "x, y"
                what = "inside" if gap < 0.0 else f"{gap:.3f} m from"
                raise Blocked(
                    f"{where}: ({x:g}, {y:g}) is {what} {s.name}: the robot keeps {planner.clearance:.3f} m clear "
                    "([robot] radius + [field] margin)"
                )


def route(goal: Goal, start: Point, radius: float, planner: Planner, corner_tolerance: float) -> Goal:
    """The goal with detours between its points where the straight way is blocked (the goal itself when none is)."""
    if goal.state not in PLANNED or not planner.shapes:
        return goal
    check_targets(goal, planner)
    for s in planner.shapes:
        gap = s.clearance(*start)
        if gap < radius:
            raise Blocked(
                f"the robot at ({start[0]:.3f}, {start[1]:.3f}) overlaps {s.name} ({gap:.3f} m from it, its footprint "
                f"{radius:.3f} m): drive it clear first (a move_straight, or plan: false)"
            )
    tols = goal.point_tolerances or tuple(corner_tolerance for _ in goal.points[:-1]) + (goal.tolerance,)
    points: list[Point] = []
    tolerances: list[float] = []
    here = start
    for i, target in enumerate(goal.points):
        try:
            way = planner.plan(here, target)
        except NoPath as e:
            where = f"points[{i}]" if goal.state == State.FOLLOWING_PATH else "x, y"
            raise Blocked(f"{where}: {e}") from None
        points += way
        tolerances += [corner_tolerance] * (len(way) - 1) + [tols[i]]
        here = target
    if len(points) == len(goal.points):
        return goal
    return replace(goal, points=tuple(points), point_tolerances=tuple(tolerances))
