"""The goal state machine: one goal at a time, from start to succeeded, cancelled or aborted.

Pure: poses and the time come in as arguments. `on_pose` returns the command for
that pose; `check` (called periodically) aborts on a stale or too uncertain pose, or no
progress, and ends a goal whose time-out ran out. Too uncertain (`[navigator]
max_position_sigma`, `max_heading_sigma`) counts only while the machine is `gated`: a pose
with an absolute reference to lose (a VPS); on odometry alone every pose grows more
uncertain with the distance driven, and the goal drives on. How a move ends is in exits.py: the
goal's tolerance ends it as soon as the error is within it and the robot stops within it
(judged on the pose predicted `stop_lead` ahead); then zero is held for `rest_time` and
the error is re-checked: `succeeded` only if still within the tolerance.
Within `lock_distance` of its final point a move stops turning toward it (no heading
swing on arrival) and drives straight on, braking to reach the tolerance's edge at the
speed whose coast ends on the point. A move_to_pose then turns in place to its heading.
follow_path passes its intermediate points, each within its own tolerance, without
stopping (no slower than `through_speed`, but for the turn limit).
A backwards goal (LemLib's `forwards = false`) runs the same machine on the robot seen
from behind: its pose turned half a turn and its speed negated, a move_to_pose's heading
likewise, and the commanded speed negated back; every controller drives it unchanged.
A chained goal (`min_speed` > 0: LemLib's motion chaining) never slows below min_speed
and ends, `chained`, once the robot crosses the line across its approach (a turn: its
heading) `early_exit_range` before the target; its last command is then held for
`chain_time`, so that the next goal takes over at speed (`coasting`).
A turn told its direction (LemLib's AngularDirection: +1 counter-clockwise, -1 clockwise)
turns that way round, the long way if need be, and the shorter way once within RELEASE.
A swing (LemLib's swingToHeading) is a turn about one wheel, which is commanded to stand still.
Every end but a handover to a new goal or a chained end asks for zero velocity at once (`End.stop`).
The robot stays in the field: a goal whose target lies outside is refused
(`outside`), and a running goal aborts when the pose leaves it. A move_straight
without a distance aborts after `straight_max_time`.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import NamedTuple

from zenav.common.config import Field
from zenav.common.contract import Exit, GoalResult, Reason, State
from zenav.common.geometry import wrap_angle
from zenav.services.navigator import controllers
from zenav.services.navigator.controllers import PoseSample, Wheelbase
from zenav.services.navigator.exits import Hold
from zenav.services.navigator.goal import (
    End,
    Feedback,
    Goal,
    Run,
    aimed,
    behind,
    final_error,
    left_of,
    outside,
    path_rest,
    verdict,
)
from zenav.services.navigator.params import Params
from zenav.services.navigator.steering import MAX_SWITCHES, Steering

__all__ = [  # the names the navigator's service and the tests import from here
    "MAX_SWITCHES",
    "End",
    "Feedback",
    "Goal",
    "GoalMachine",
    "Refusal",
    "Refused",
    "outside",
    "path_rest",
]

FACE_OFF_LINE = 0.8  # [-] a correction turns to face its point first when it lies this many tolerances off the heading line,
FIELD_SLACK = 0.02  # [m] a goal started outside the field may take the robot this much farther out (a turn, the pose's noise)
SLIPPED = " (the wheels slipped: held by a wall or a robot?)"  # ends a move's failure where the wheels slipped
NOISE_SIGMAS = 2.0  # [-] plus this many position sigmas: an offset the estimate's noise explains is not chased by a turn


class Refusal(NamedTuple):
    """Why no goal can start now: the contract's code, and the words."""

    reason: Reason
    message: str


class Refused(Exception):
    """A goal that cannot start: no pose yet, or the pose is stale or too uncertain."""

    def __init__(self, refusal: Refusal) -> None:
        super().__init__(refusal.message)
        self.reason = refusal.reason


class GoalMachine(Steering):
    """The navigator's state: State.STOPPED or running one goal."""

    def __init__(self, params: Params, wheels: Wheelbase, area: Field | None = None, gated: bool = True) -> None:
        self.params, self.wheels = params, wheels
        self.gated = gated  # an uncertain pose refuses and aborts goals (a VPS runs); else it is only reported
        self.area = area or Field(enabled=False)
        self.state: str = State.STOPPED
        self.goal_id = 0  # id of the newest goal
        self.goal: Goal | None = None  # the newest goal (kept after it ends)
        self.result: str | None = None  # result of the newest goal; None while it runs
        self.exit: str | None = None  # why the newest goal's move ended; None while it runs
        self.message = ""
        self.pose: PoseSample | None = None  # newest pose
        self._cmd = (0.0, 0.0)  # (v [m/s], omega [rad/s]) last commanded
        self._rate = (0.0, 0.0)  # (v [m/s], omega [rad/s]) the commands through a first-order lag of stop_lead
        self._coast: float | None = None  # [s] pose t until which a chained goal's last command is held
        self._run: Run | None = None

    @property
    def active(self) -> bool:
        """Whether a goal is running."""
        return self._run is not None

    def refusal(self, now: float) -> Refusal | None:
        """Why no goal can start now (no pose, stale pose, uncertain pose), or None."""
        if self.pose is None:
            return Refusal(Reason.NO_POSE, "no pose yet: is the localizer running?")
        if now - self.pose.since > self.params.stale_after:
            return Refusal(Reason.POSE_STALE, f"pose stale: the newest is {now - self.pose.since:.2f} s old")
        doubt = self.uncertain() if self.gated else None
        if doubt is not None:
            return Refusal(Reason.POSE_UNCERTAIN, f"{doubt} (no VPS fix yet or for long: wait for one, or set the pose)")
        return None

    def uncertain(self) -> str | None:
        """Why the newest pose is too uncertain to drive on, or None."""
        p, pose = self.params, self.pose
        if pose is None:
            return "no pose yet"
        if pose.sigma_xy > p.max_position_sigma:
            return f"pose too uncertain: position sigma {pose.sigma_xy:.3f} m > {p.max_position_sigma:.3f} m"
        if pose.sigma_theta > p.max_heading_sigma:
            return f"pose too uncertain: heading sigma {pose.sigma_theta:.3f} rad > {p.max_heading_sigma:.3f} rad"
        return None

    def start(self, goal: Goal, now: float) -> End | None:
        """Start a goal, preempting the running one (its End, a handover, is returned)."""
        reason = self.refusal(now)
        if reason is not None:
            raise Refused(reason)
        pose = self.pose
        assert pose is not None  # no refusal: there is a pose
        preempted = self._end(GoalResult.CANCELLED, f"preempted by goal {self.goal_id + 1}", stop=False, exit=Exit.CANCELLED)
        self._coast = None  # the new goal takes over from a chained one's held command
        self.goal_id += 1
        self.goal, self.state, self.result, self.exit, self.message = goal, goal.state, None, None, ""
        p = self.params
        timeout = goal.timeout or p.goal_timeout
        out = self.area.beyond(pose.x, pose.y)
        beyond = out + FIELD_SLACK if out > 0 else 0.0  # started outside: it may bring the robot back in
        deadline = now + timeout if timeout > 0 else math.inf
        if goal.backwards:  # the run drives the robot seen from behind, to the heading its back arrives with
            goal, pose = replace(goal, heading=wrap_angle(goal.heading + math.pi)), behind(pose)
        run = self._run = Run(goal, now, pose, beyond, Hold(p.settle_time), Hold(p.big_time), deadline)
        if goal.state == State.TURNING_TO_HEADING:
            err = wrap_angle(goal.heading - pose.theta)
            run.forced = goal.direction != 0 and abs(err) > goal.tolerance  # told its way, and not there already
            run.way = float(goal.direction) if run.forced else math.copysign(1.0, err)
        if goal.points:
            run.rest = path_rest(goal.points)
            self._aim(run, pose)
        cmd = self._step(run, pose)  # feedback and progress from the start
        if cmd is None and run.exit != Exit.CHAINED:  # already there (a chained goal already there ends on the next pose)
            self._stop(run, pose)
        run.best, run.best_t = run.progress, now
        return preempted

    def cancel(self, message: str) -> End | None:
        """Cancel the running goal (stop, lease...), and a chained goal's held command; None if there is no goal."""
        self._coast = None
        return self._end(GoalResult.CANCELLED, message, stop=True, exit=Exit.CANCELLED)

    def abort(self, message: str, exit: str = Exit.ABORTED) -> End | None:
        """Abort the running goal, and a chained goal's held command; None if there is no goal."""
        self._coast = None
        return self._end(GoalResult.ABORTED, message, stop=True, exit=exit)

    @property
    def coasting(self) -> bool:
        """Whether a chained goal's last command is still held (no goal runs)."""
        return self._coast is not None

    def reset(self, message: str) -> End | None:
        """Time started again (sim restart): abort the goal and forget the pose."""
        end = self.abort(message)
        self.pose = None
        return end

    def heard(self, pose: PoseSample) -> None:
        """A pose that is not steered on (control on odom: the odom samples are): its age and uncertainty count at
        once, and it is the newest pose unless a sample after its t was steered on already."""
        if self.pose is None or pose.t >= self.pose.t:
            self.pose = pose
        else:
            self.pose = self.pose._replace(sigma_xy=pose.sigma_xy, sigma_theta=pose.sigma_theta, slipping=pose.slipping, pose_t=pose.t)

    def on_pose(self, pose: PoseSample) -> tuple[tuple[float, float] | None, End | None]:
        """Take a pose: the (v, omega) to command (None when idle), and the End if the goal ended."""
        self._lag(pose.t)
        self.pose = pose
        run = self._run
        if run is None:
            return self._held(pose.t), None
        out = self.area.beyond(pose.x, pose.y)
        if out > run.beyond:
            farther = f", farther out than the goal's start allows ({run.beyond:.3f} m)" if run.beyond else ""
            return (0.0, 0.0), self.abort(f"left the field: {self.area.outside(pose.x, pose.y)}{farther}")
        if out == 0.0:
            run.beyond = 0.0  # inside (again): the field's bounds hold
        run.slipped = run.slipped or pose.slipping
        if run.sign < 0.0:
            pose = behind(pose)
        if run.settle_from is None:
            cmd = None if run.exit == Exit.CHAINED else self._step(run, pose)
            if cmd is not None:
                self._cmd = controllers.limit(run.sign * cmd[0], cmd[1], self.params.max_turn_speed, self.wheels)
                return self._cmd, None
            if run.exit == Exit.CHAINED:
                return self._chained(run, pose)
            self._stop(run, pose)
        assert run.settle_from is not None and run.exit is not None  # stopped
        resting = pose.t - run.settle_from
        # While the wheels slip the position waits for the fixes: a robot held short by a wall has not "arrived".
        waiting = pose.slipping and resting < self.params.rest_time + self.params.slip_wait
        if resting >= self.params.rest_time and not waiting:
            result, message = verdict(run.goal, run.origin, pose, run.exit)
            if result != GoalResult.SUCCEEDED and run.slipped:
                message += SLIPPED
            if result == GoalResult.SUCCEEDED or not self._retry(run, pose):
                return (0.0, 0.0), self._end(result, message, stop=True, exit=run.exit)
            return self.on_pose(self.pose)
        return (0.0, 0.0), None

    def check(self, now: float) -> End | None:
        """Periodic checks: abort on a stale pose or no progress for too long; stop at the time-out."""
        run, p, pose = self._run, self.params, self.pose
        if run is None or pose is None:  # a goal runs only from a pose
            return None
        if now - pose.since > p.stale_after:
            return self.abort(f"pose stale: none for {now - pose.since:.2f} s")
        doubt = self.uncertain() if self.gated else None
        if doubt is not None:
            return self.abort(doubt)
        if run.goal.state == State.MOVING_STRAIGHT and run.goal.distance is None and now - run.start_t >= p.straight_max_time:
            message = f"move_straight without a distance stops after straight_max_time = {p.straight_max_time:g} s"
            return self.abort(message, Exit.TIMEOUT)
        if run.settle_from is None and now >= run.deadline:
            run.exit = Exit.TIMEOUT
            self._stop(run, pose)  # zero from the next pose on, then the error is re-checked
        angular = run.goal.state == State.TURNING_TO_HEADING or run.turning or run.facing
        step = p.progress_angle if angular else p.progress_distance
        if run.settle_from is not None or run.best is None or run.progress >= run.best + step:
            run.best, run.best_t = run.progress, now
        elif now - run.best_t > p.progress_timeout:
            return self.abort(f"no progress for {now - run.best_t:.1f} s{SLIPPED if run.slipped else ''}", Exit.STALLED)
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
            next_point=run.index if run.goal.state == State.FOLLOWING_PATH else None,
            cross_track_error=run.cross_track,
        )

    # ------------------------------------------------------------ internals
    def _lag(self, t: float) -> None:
        """Follow the robot's rates from the commands: a stop coasts about rate x stop_lead.

        Modelled rather than measured: encoder rates are too coarse at the low speeds of an arrival.
        """
        dt = 0.0 if self.pose is None else max(t - self.pose.t, 0.0)
        a = 1.0 if self.params.stop_lead <= 0.0 else min(1.0, dt / self.params.stop_lead)
        self._rate = (
            self._rate[0] + a * (self._cmd[0] - self._rate[0]),
            self._rate[1] + a * (self._cmd[1] - self._rate[1]),
        )

    def _end(self, result: str, message: str, stop: bool, exit: str) -> End | None:
        if self._run is None:
            return None
        self._run = None
        if stop:
            self._cmd = (0.0, 0.0)
        self.state, self.result, self.exit, self.message = State.STOPPED, result, exit, message
        return End(self.goal_id, result, message, stop, exit)

    def _chained(self, run: Run, pose: PoseSample) -> tuple[tuple[float, float], End | None]:
        """A chained goal crossed its exit line: it succeeds at once, its last command held for chain_time."""
        self._coast = pose.t + self.params.chain_time
        dist, turn = final_error(run.goal, run.origin, pose)
        off = f"{math.degrees(turn):.1f} deg" if run.goal.state == State.TURNING_TO_HEADING else f"{dist * 100:.1f} cm"
        return self._cmd, self._end(GoalResult.SUCCEEDED, f"chained {off} from the target, at speed", stop=False, exit=Exit.CHAINED)

    def _held(self, t: float) -> tuple[float, float] | None:
        """No goal runs: a chained goal's last command until chain_time has passed, then zero once; else None."""
        if self._coast is None:
            return None
        if t >= self._coast:
            self._coast, self._cmd = None, (0.0, 0.0)
        return self._cmd

    def _stop(self, run: Run, pose: PoseSample) -> None:
        """The move ends at `pose` (run.exit says why): zero from now on, the error re-checked after rest_time."""
        run.settle_from, run.held, self._cmd = pose.t, pose.slipping, (0.0, 0.0)
        run.slipped = run.slipped or pose.slipping
        run.exit = run.exit or Exit.WITHIN_TOLERANCE
        run.remaining = 0.0 if run.remaining is not None else None

    def _retry(self, run: Run, pose: PoseSample) -> bool:
        """Move again after a re-check over the tolerance (a late fix moved the pose), up to `retries` times.

        Only a move that ended at its target (within_tolerance, passed) is corrected, a path from its last point:
        straight on (forwards or back) when the point lies near the heading line (within FACE_OFF_LINE of the
        tolerance, straight on then ends within it, or within what the estimate's noise explains); else first
        turning in place to face it (or to back onto it, whichever turn is smaller). Not a move that stopped with
        its wheels slipping: a wall or a robot held it, and moving again would push into it again.
        """
        if run.exit not in (Exit.WITHIN_TOLERANCE, Exit.PASSED) or run.retries >= self.params.retries or run.held:
            return False
        if run.goal.state == State.MOVING_STRAIGHT:
            return False
        run.retries += 1
        run.settle_from, run.exit, run.turning = None, None, False
        if run.goal.points:
            run.index = len(run.goal.points) - 1
            self._aim(run, pose)
            target = aimed(run)
            run.locked = True
            off_line = FACE_OFF_LINE * run.goal.tolerance + NOISE_SIGMAS * pose.sigma_xy  # [m]
            run.facing = abs(left_of(pose.x, pose.y, pose.theta, target.x, target.y)) > off_line
        run.small.reset()
        run.big.reset()
        return True
