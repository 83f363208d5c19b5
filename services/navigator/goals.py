"""The goal state machine: one goal at a time, from start to succeeded, cancelled or aborted.

Pure: poses and the time come in as arguments. `on_pose` returns the command for
that pose; `check` (called periodically) aborts on a stale or too uncertain pose, or no progress.
Every end but a handover to a new goal asks for zero velocity at once (`End.stop`).
A position goal arrives when it is within tolerance and no longer ahead (seen from
the pose predicted `stop_lead` ahead, the point is off the direction of travel by
more than APPROACH_CONE: driving on would not bring it closer), a turn when it is
within tolerance and the predicted heading reaches the target; then zero is held
for `settle_time` and the goal succeeds: "arrived" means stopped.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Optional

from zenav.common.geometry import wrap_angle
from zenav.services.navigator import controllers
from zenav.services.navigator.controllers import PoseSample, Target, Wheelbase
from zenav.services.navigator.params import Params
from zenav.services.navigator.turning import profile_speed, turn_command

STOPPED = "STOPPED"
MOVING_TO_POINT = "MOVING_TO_POINT"
TURNING_TO_HEADING = "TURNING_TO_HEADING"
MOVING_STRAIGHT = "MOVING_STRAIGHT"
FOLLOWING_PATH = "FOLLOWING_PATH"
SUCCEEDED, CANCELLED, ABORTED = "succeeded", "cancelled", "aborted"
APPROACH_CONE = math.pi / 3  # [rad] inside tolerance, a goal point further off the travel direction is reached


class Refused(Exception):
    """A goal that cannot start: no pose yet, or the pose is stale."""


@dataclass(frozen=True)
class Goal:
    """What to do, with speeds and tolerances already resolved and clamped."""

    state: str  # the navigator state the goal runs in
    points: tuple[tuple[float, float], ...] = ()  # [m] in order (move_to_point: one)
    heading: float = 0.0  # [rad] turn target
    speed: float = 0.0  # [m/s] forward limit, signed for move_straight; [rad/s] for turns
    tolerance: float = 0.0  # [m]; [rad] for turns
    distance: Optional[float] = None  # [m] move_straight: stop after this far (None: until stopped)


@dataclass(frozen=True)
class End:
    """How a goal ended."""

    goal_id: int
    result: str  # succeeded, cancelled, aborted
    message: str
    stop: bool  # command zero velocity now (every end but a handover)


@dataclass(frozen=True)
class Feedback:
    """Progress of the running goal (all None when there is none)."""

    distance_remaining: Optional[float] = None  # [m]; [rad] for turns
    heading_error: Optional[float] = None  # [rad]
    eta: Optional[float] = None  # [s]
    elapsed: float = 0.0  # [s]
    next_point: Optional[int] = None  # follow_path: index of the point being approached
    cross_track_error: Optional[float] = None  # [m] left of the segment or line is positive


@dataclass
class _Run:
    goal: Goal
    start_t: float  # [s] clock time the goal started
    origin: PoseSample  # pose when it started
    rest: list[float] = field(default_factory=list)  # [m] path length after each point
    index: int = 0  # point being approached
    target: Optional[Target] = None
    controller: Optional[controllers.Controller] = None
    settle_from: Optional[float] = None  # [s] pose t of arrival
    progress: float = 0.0  # gain toward the current target, larger is better
    best: Optional[float] = None  # best progress so far (None: invalidated, take the next)
    best_t: float = 0.0  # [s] clock time of the last progress
    remaining: Optional[float] = None
    heading_error: Optional[float] = None
    cross_track: Optional[float] = None


def _lateral(ox: float, oy: float, heading: float, x: float, y: float) -> float:
    """Signed offset [m] of (x, y) left of the line through (ox, oy) along `heading`."""
    return -(x - ox) * math.sin(heading) + (y - oy) * math.cos(heading)


class GoalMachine:
    """The navigator's state: STOPPED or running one goal."""

    def __init__(self, params: Params, wheels: Wheelbase) -> None:
        self.params, self.wheels = params, wheels
        self.state = STOPPED
        self.goal_id = 0  # id of the newest goal
        self.goal: Optional[Goal] = None  # the newest goal (kept after it ends)
        self.result: Optional[str] = None  # result of the newest goal; None while it runs
        self.message = ""
        self.pose: Optional[PoseSample] = None  # newest pose
        self._cmd = (0.0, 0.0)  # (v [m/s], omega [rad/s]) last commanded: the rate the arrival is predicted at
        self._run: Optional[_Run] = None

    @property
    def active(self) -> bool:
        """Whether a goal is running."""
        return self._run is not None

    def refusal(self, now: float) -> Optional[str]:
        """Why no goal can start now (no pose, stale pose, uncertain pose), or None."""
        if self.pose is None:
            return "no pose yet: is the localizer running?"
        if now - self.pose.t > self.params.stale_after:
            return f"pose stale: the newest is {now - self.pose.t:.2f} s old"
        doubt = self.uncertain()
        if doubt is not None:
            return f"{doubt} (no VPS fix yet or for long: wait for one, or set the pose)"
        return None

    def uncertain(self) -> Optional[str]:
        """Why the newest pose is too uncertain to drive on, or None."""
        p, pose = self.params, self.pose
        if pose.sigma_xy > p.max_position_sigma:
            return f"pose too uncertain: position sigma {pose.sigma_xy:.3f} m > {p.max_position_sigma:.3f} m"
        if pose.sigma_theta > p.max_heading_sigma:
            return f"pose too uncertain: heading sigma {pose.sigma_theta:.3f} rad > {p.max_heading_sigma:.3f} rad"
        return None

    def start(self, goal: Goal, now: float) -> Optional[End]:
        """Start a goal, preempting the running one (its End, a handover, is returned)."""
        reason = self.refusal(now)
        if reason is not None:
            raise Refused(reason)
        preempted = self._end(CANCELLED, f"preempted by goal {self.goal_id + 1}", stop=False)
        self.goal_id += 1
        self.goal, self.state, self.result, self.message = goal, goal.state, None, ""
        run = self._run = _Run(goal, now, self.pose)
        if goal.points:
            legs = [math.dist(a, b) for a, b in zip(goal.points, goal.points[1:])]
            run.rest = [sum(legs[i:]) for i in range(len(goal.points))]
            self._aim(run, self.pose)
        self._step(run, self.pose)  # feedback and progress from the start
        run.best, run.best_t = run.progress, now
        return preempted

    def cancel(self, message: str) -> Optional[End]:
        """Cancel the running goal (stop, lease...); None if there is none."""
        return self._end(CANCELLED, message, stop=True)

    def abort(self, message: str) -> Optional[End]:
        """Abort the running goal; None if there is none."""
        return self._end(ABORTED, message, stop=True)

    def reset(self, message: str) -> Optional[End]:
        """Time started again (sim restart): abort the goal and forget the pose."""
        end = self.abort(message)
        self.pose = None
        return end

    def on_pose(self, pose: PoseSample) -> tuple[Optional[tuple[float, float]], Optional[End]]:
        """Take a pose: the (v, omega) to command (None when idle), and the End if the goal ended."""
        self.pose = pose
        run = self._run
        if run is None:
            return None, None
        if run.settle_from is None:
            cmd = self._step(run, pose)
            if cmd is not None:
                self._cmd = controllers.limit(*cmd, self.params.max_turn_speed, self.wheels)
                return self._cmd, None
            run.settle_from, self._cmd = pose.t, (0.0, 0.0)
            run.remaining = 0.0 if run.remaining is not None else None
        if pose.t - run.settle_from >= self.params.settle_time:
            return (0.0, 0.0), self._end(SUCCEEDED, "arrived", stop=True)
        return (0.0, 0.0), None

    def check(self, now: float) -> Optional[End]:
        """Periodic checks: abort on a stale pose or no progress for too long."""
        run, p = self._run, self.params
        if run is None:
            return None
        if now - self.pose.t > p.stale_after:
            return self.abort(f"pose stale: none for {now - self.pose.t:.2f} s")
        doubt = self.uncertain()
        if doubt is not None:
            return self.abort(doubt)
        step = p.progress_angle if run.goal.state == TURNING_TO_HEADING else p.progress_distance
        if run.settle_from is not None or run.best is None or run.progress >= run.best + step:
            run.best, run.best_t = run.progress, now
        elif now - run.best_t > p.progress_timeout:
            return self.abort(f"no progress for {now - run.best_t:.1f} s")
        return None

    def feedback(self, now: float) -> Feedback:
        """Distance remaining, errors, ETA and elapsed time of the running goal."""
        run = self._run
        if run is None:
            return Feedback()
        speed = abs(run.goal.speed)
        eta = run.remaining / speed if run.remaining is not None and speed > 0 else None
        return Feedback(
            distance_remaining=run.remaining,
            heading_error=run.heading_error,
            eta=eta,
            elapsed=now - run.start_t,
            next_point=run.index if run.goal.state == FOLLOWING_PATH else None,
            cross_track_error=run.cross_track,
        )

    # ------------------------------------------------------------ internals
    def _end(self, result: str, message: str, stop: bool) -> Optional[End]:
        if self._run is None:
            return None
        self._run = None
        if stop:
            self._cmd = (0.0, 0.0)
        self.state, self.result, self.message = STOPPED, result, message
        return End(self.goal_id, result, message, stop)

    def _aim(self, run: _Run, pose: PoseSample) -> None:
        """Target the current point: a fresh controller, and the old progress invalidated."""
        x, y = run.goal.points[run.index]
        reverse_ok = self.params.controller == "polar"
        run.target = controllers.make_target(pose, x, y, run.goal.speed, reverse_ok)
        run.controller = controllers.make(self.params.controller)
        run.best = None

    def _step(self, run: _Run, pose: PoseSample) -> Optional[tuple[float, float]]:
        """The command for this pose; None once arrived. Updates feedback and progress."""
        if run.goal.state == TURNING_TO_HEADING:
            return self._step_turn(run, pose)
        if run.goal.state == MOVING_STRAIGHT:
            return self._step_straight(run, pose)
        return self._step_points(run, pose)

    def _step_points(self, run: _Run, pose: PoseSample) -> Optional[tuple[float, float]]:
        p, lead, v = self.params, self.params.stop_lead, self._cmd[0]
        px = pose.x + v * math.cos(pose.theta) * lead  # [m] predicted position
        py = pose.y + v * math.sin(pose.theta) * lead
        while True:
            target = run.target
            dist = math.hypot(target.x - pose.x, target.y - pose.y)
            inside = min(dist, math.hypot(target.x - px, target.y - py)) <= run.goal.tolerance
            last = run.index + 1 == len(run.goal.points)
            # The last point is reached once it no longer lies ahead, within APPROACH_CONE of the
            # direction of travel, of the predicted position: driving on would not bring it closer.
            travel = pose.theta + (math.pi if target.reverse else 0.0)
            off = abs(wrap_angle(math.atan2(target.y - py, target.x - px) - travel))
            if not inside or (last and off < APPROACH_CONE):
                break
            if last:
                return None
            run.index += 1  # switch: the old target's distance and progress no longer count
            self._aim(run, pose)
        start = run.goal.points[run.index - 1] if run.index else (run.origin.x, run.origin.y)
        seg_heading = math.atan2(target.y - start[1], target.x - start[0])
        bearing = wrap_angle(math.atan2(target.y - pose.y, target.x - pose.x) - pose.theta)
        run.remaining = dist + run.rest[run.index]
        run.heading_error = wrap_angle(bearing + math.pi) if target.reverse else bearing
        run.cross_track = _lateral(start[0], start[1], seg_heading, pose.x, pose.y)
        run.progress = -dist
        return run.controller(pose, target, p)

    def _step_turn(self, run: _Run, pose: PoseSample) -> Optional[tuple[float, float]]:
        p, goal = self.params, run.goal
        err = wrap_angle(goal.heading - pose.theta)
        run.remaining, run.heading_error, run.progress = abs(err), err, -abs(err)
        omega = turn_command(err, self._cmd[1], goal.speed, goal.tolerance, p.turn_decel, p.min_turn_speed, p.stop_lead)
        return None if omega is None else (0.0, omega)

    def _step_straight(self, run: _Run, pose: PoseSample) -> Optional[tuple[float, float]]:
        p, goal, o = self.params, run.goal, run.origin
        sign = math.copysign(1.0, goal.speed)
        travelled = sign * ((pose.x - o.x) * math.cos(o.theta) + (pose.y - o.y) * math.sin(o.theta))
        lateral = _lateral(o.x, o.y, o.theta, pose.x, pose.y)
        # Head back toward the line: ahead of the robot when forward, behind it when reversing.
        want = wrap_angle(o.theta - sign * math.atan(p.straight_track_gain * lateral))
        run.heading_error = wrap_angle(want - pose.theta)
        run.cross_track, run.progress = lateral, travelled
        omega = p.straight_heading_gain * run.heading_error
        if goal.distance is None:
            return goal.speed, omega
        left = goal.distance - travelled
        run.remaining = max(left, 0.0)
        ahead = left - abs(self._cmd[0]) * p.stop_lead  # [m] predicted left after the lead
        if ahead <= 0.0:
            return None
        return sign * profile_speed(ahead, p.decel, p.min_speed, abs(goal.speed)), omega
