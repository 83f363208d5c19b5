"""One goal: what it asks (Goal), how it ended (End), its progress (Feedback), the state of its run (Run),
and how its end is judged (final_error, verdict). Pure: poses come in as arguments."""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from operator import itemgetter

from zenav.common.config import Field
from zenav.common.contract import GoalResult, State
from zenav.common.geometry import wrap_angle
from zenav.services.navigator import controllers
from zenav.services.navigator.controllers import PoseSample, Target
from zenav.services.navigator.exits import Hold


@dataclass(frozen=True)
class Goal:
    """What to do, with speeds and tolerances already resolved and clamped."""

    state: str  # the navigator state the goal runs in
    points: tuple[tuple[float, float], ...] = ()  # [m] in order (move_to_point, move_to_pose: one)
    heading: float = 0.0  # [rad] turn target; move_to_pose: the final heading
    speed: float = 0.0  # [m/s] forward limit, signed for move_straight; [rad/s] for turns
    tolerance: float = 0.0  # [m] of the final point; [rad] for turns
    distance: float | None = None  # [m] move_straight: stop after this far (None: until stopped)
    heading_tolerance: float = 0.0  # [rad] move_to_pose: of the final heading
    point_tolerances: tuple[float, ...] = ()  # [m] follow_path: of each point ((): waypoint_tolerance, the last `tolerance`)
    lead: float = 0.0  # [-] move_to_pose with the boomerang: carrot distance per metre to the goal
    timeout: float = 0.0  # [s] stop after this long (exit timeout); 0: [navigator] goal_timeout
    backwards: bool = False  # move_to_point, move_to_pose, follow_path: drive with the robot's back ahead
    min_speed: float = 0.0  # [m/s] ([rad/s] for turns) > 0: a chained goal, no slower than this, ending at speed
    early_exit_range: float = 0.0  # [m] ([rad] for turns) a chained goal ends this far before its target
    direction: int = 0  # turns: +1 counter-clockwise, -1 clockwise (the long way round if need be), 0 the shorter way
    pivot: int = 0  # turns: 0 in place; a swing about its still wheel, +1 the left, -1 the right


@dataclass(frozen=True)
class End:
    """How a goal ended."""

    goal_id: int
    result: str  # succeeded, cancelled, aborted
    message: str
    stop: bool  # command zero velocity now (every end but a handover)
    exit: str = ""  # why the move ended (a contract.Exit)


@dataclass(frozen=True)
class Feedback:
    """Progress of the running goal (all None when there is none)."""

    distance_remaining: float | None = None  # [m]; [rad] for turns
    heading_error: float | None = None  # [rad]
    eta: float | None = None  # [s]
    elapsed: float = 0.0  # [s]
    next_point: int | None = None  # follow_path: index of the point being approached
    cross_track_error: float | None = None  # [m] left of the segment or line is positive


@dataclass
class Run:
    """A running goal: what it started from, where it is, and how it is going (the state the machine steps)."""

    goal: Goal
    start_t: float  # [s] clock time the goal started
    origin: PoseSample  # pose when it started (as the run sees it: from behind when backwards)
    beyond: float  # [m] how far outside the field the goal may take the robot (0: it started inside)
    small: Hold  # the settle_error band
    big: Hold  # the big_error band
    deadline: float = math.inf  # [s] clock time of the time-out
    rest: list[float] = field(default_factory=list)  # [m] path length after each point
    index: int = 0  # point being approached
    target: Target | None = None
    controller: controllers.Controller | None = None
    locked: bool = False  # within lock_distance of the final point: no more turning toward it
    turning: bool = False  # move_to_pose: at the point, turning to the heading
    facing: bool = False  # a correction: turning in place to face the point (it lies off the heading line)
    exit: str | None = None  # why the move ended (set when it stops)
    retries: int = 0  # corrections made after a re-check over the tolerance
    settle_from: float | None = None  # [s] pose t of the stop
    progress: float = 0.0  # gain toward the current target, larger is better
    best: float | None = None  # best progress so far (None: invalidated, take the next)
    best_t: float = 0.0  # [s] clock time of the last progress
    remaining: float | None = None
    heading_error: float | None = None
    cross_track: float | None = None
    along: float | None = None  # [m] or [rad] a chained goal: how far before the target's line it was on the last pose
    way: float = 0.0  # a turn: +1 counter-clockwise, -1 clockwise, as it started
    forced: bool = False  # a turn told its direction, not yet within RELEASE of its heading
    slipped: bool = False  # the localizer found the wheels slipping on some pose of the goal
    held: bool = False  # ... on the pose the move stopped at: a wall or a robot held it there

    @property
    def sign(self) -> float:
        """-1.0 for a backwards goal (driven on the robot seen from `behind`), else 1.0: the commanded speed's sign."""
        return -1.0 if self.goal.backwards else 1.0


def behind(pose: PoseSample) -> PoseSample:
    """The robot seen from behind: its back as its front (heading half a turn on, forward speed negated)."""
    return pose._replace(theta=wrap_angle(pose.theta + math.pi), v=-pose.v)


def outside(goal: Goal, pose: PoseSample, area: Field) -> str | None:
    """Why the goal's target (each point; a straight's end) lies outside the field, or None."""
    if goal.points and area.enabled:
        xs, ys = list(map(itemgetter(0), goal.points)), list(map(itemgetter(1), goal.points))
        if min(xs) < area.x_min or max(xs) > area.x_max or min(ys) < area.y_min or max(ys) > area.y_max:
            i, why = next((i, w) for i, p in enumerate(goal.points) if (w := area.outside(*p)) is not None)
            return f"points[{i}]: {why}" if goal.state == State.FOLLOWING_PATH else f"x, y: {why}"
    if goal.state == State.MOVING_STRAIGHT and goal.distance is not None:
        d = math.copysign(goal.distance, goal.speed)  # [m] along the start heading
        end = area.outside(pose.x + d * math.cos(pose.theta), pose.y + d * math.sin(pose.theta))
        if end is not None:
            return f"distance: the end is outside: {end}"
    return None


def path_rest(points: tuple[tuple[float, float], ...]) -> list[float]:
    """[m] path length after each point to the last, in one pass."""
    legs = list(map(math.dist, points[:-1], points[1:]))
    legs.reverse()  # summed from the end
    rest = list(itertools.accumulate(legs, initial=0.0))
    rest.reverse()
    return rest


def aimed(run: Run) -> Target:
    """The target of a run of points (set when it starts)."""
    assert run.target is not None
    return run.target


def left_of(ox: float, oy: float, heading: float, x: float, y: float) -> float:
    """Signed offset [m] of (x, y) left of the line through (ox, oy) along `heading`."""
    return -(x - ox) * math.sin(heading) + (y - oy) * math.cos(heading)


def final_error(goal: Goal, origin: PoseSample, pose: PoseSample) -> tuple[float, float]:
    """(position error [m], heading error [rad]) of `pose` against the goal's end (0 where it has none)."""
    if goal.state == State.TURNING_TO_HEADING:
        return 0.0, abs(wrap_angle(goal.heading - pose.theta))
    if goal.state == State.MOVING_STRAIGHT:
        travelled = (pose.x - origin.x) * math.cos(origin.theta) + (pose.y - origin.y) * math.sin(origin.theta)
        return abs(abs(travelled) - (goal.distance or 0.0)), 0.0
    x, y = goal.points[-1]
    turn = abs(wrap_angle(goal.heading - pose.theta)) if goal.state == State.MOVING_TO_POSE else 0.0
    return math.hypot(x - pose.x, y - pose.y), turn


def verdict(goal: Goal, origin: PoseSample, pose: PoseSample, exit: str) -> tuple[str, str]:
    """(result, message) of a move that stopped on `exit`, from its error re-checked at `pose`."""
    dist, turn = final_error(goal, origin, pose)
    fails = []
    if goal.state == State.TURNING_TO_HEADING:
        if turn > goal.tolerance:
            fails.append(f"{math.degrees(turn):.2f} deg off the heading (tolerance {math.degrees(goal.tolerance):.2f} deg)")
    else:
        if dist > goal.tolerance:
            fails.append(f"{dist * 100:.2f} cm from the goal (tolerance {goal.tolerance * 100:.2f} cm)")
        if goal.state == State.MOVING_TO_POSE and turn > goal.heading_tolerance:
            fails.append(f"{math.degrees(turn):.2f} deg off the heading (tolerance {math.degrees(goal.heading_tolerance):.2f} deg)")
    if not fails:
        return GoalResult.SUCCEEDED, "arrived"
    return GoalResult.ABORTED, f"stopped {' and '.join(fails)}: exit {exit}"
