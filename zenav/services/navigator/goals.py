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

import itertools
import math
from dataclasses import dataclass, field, replace
from operator import itemgetter

from zenav.common.config import Field
from zenav.common.geometry import wrap_angle
from zenav.common.navgoals import STOPPED, TURNING_TO_HEADING
from zenav.services.navigator import controllers, exits
from zenav.services.navigator.controllers import PoseSample, Target, Wheelbase
from zenav.services.navigator.exits import Hold
from zenav.services.navigator.params import Params
from zenav.services.navigator.turning import profile_speed, turn_command

MOVING_TO_POINT = "MOVING_TO_POINT"
MOVING_TO_POSE = "MOVING_TO_POSE"
MOVING_STRAIGHT = "MOVING_STRAIGHT"
FOLLOWING_PATH = "FOLLOWING_PATH"
SUCCEEDED, CANCELLED, ABORTED = "succeeded", "cancelled", "aborted"
STATES = (STOPPED, MOVING_TO_POINT, MOVING_TO_POSE, TURNING_TO_HEADING, MOVING_STRAIGHT, FOLLOWING_PATH)  # nav/state's `state`
RESULTS = (SUCCEEDED, CANCELLED, ABORTED)  # a goal's `result`
FACE_OFF_LINE = 0.8  # [-] a correction turns to face its point first when it lies this many tolerances off the heading line,
FIELD_SLACK = 0.02  # [m] a goal started outside the field may take the robot this much farther out (a turn, the pose's noise)
SLIPPED = " (the wheels slipped: held by a wall or a robot?)"  # ends a move's failure where the wheels slipped
NOISE_SIGMAS = 2.0  # [-] plus this many position sigmas: an offset the estimate's noise explains is not chased by a turn
MAX_SWITCHES = 256  # path points passed on one pose at most (bunched points: the rest on the next poses)
RELEASE = math.pi / 4  # [rad] a turn told its direction turns the shorter way once this close (an overshoot is no full turn)


class Refused(Exception):
    """A goal that cannot start: no pose yet, or the pose is stale."""


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
    exit: str = ""  # why the move ended (exits.EXITS)


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
class _Run:
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
            return f"points[{i}]: {why}" if goal.state == FOLLOWING_PATH else f"x, y: {why}"
    if goal.state == MOVING_STRAIGHT and goal.distance is not None:
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


def _aimed(run: _Run) -> Target:
    """The target of a run of points (set when it starts)."""
    assert run.target is not None
    return run.target


def _lateral(ox: float, oy: float, heading: float, x: float, y: float) -> float:
    """Signed offset [m] of (x, y) left of the line through (ox, oy) along `heading`."""
    return -(x - ox) * math.sin(heading) + (y - oy) * math.cos(heading)


def final_error(goal: Goal, origin: PoseSample, pose: PoseSample) -> tuple[float, float]:
    """(position error [m], heading error [rad]) of `pose` against the goal's end (0 where it has none)."""
    if goal.state == TURNING_TO_HEADING:
        return 0.0, abs(wrap_angle(goal.heading - pose.theta))
    if goal.state == MOVING_STRAIGHT:
        travelled = (pose.x - origin.x) * math.cos(origin.theta) + (pose.y - origin.y) * math.sin(origin.theta)
        return abs(abs(travelled) - (goal.distance or 0.0)), 0.0
    x, y = goal.points[-1]
    turn = abs(wrap_angle(goal.heading - pose.theta)) if goal.state == MOVING_TO_POSE else 0.0
    return math.hypot(x - pose.x, y - pose.y), turn


def verdict(goal: Goal, origin: PoseSample, pose: PoseSample, exit: str) -> tuple[str, str]:
    """(result, message) of a move that stopped on `exit`, from its error re-checked at `pose`."""
    dist, turn = final_error(goal, origin, pose)
    fails = []
    if goal.state == TURNING_TO_HEADING:
        if turn > goal.tolerance:
            fails.append(f"{math.degrees(turn):.2f} deg off the heading (tolerance {math.degrees(goal.tolerance):.2f} deg)")
    else:
        if dist > goal.tolerance:
            fails.append(f"{dist * 100:.2f} cm from the goal (tolerance {goal.tolerance * 100:.2f} cm)")
        if goal.state == MOVING_TO_POSE and turn > goal.heading_tolerance:
            fails.append(f"{math.degrees(turn):.2f} deg off the heading (tolerance {math.degrees(goal.heading_tolerance):.2f} deg)")
    if not fails:
        return SUCCEEDED, "arrived"
    return ABORTED, f"stopped {' and '.join(fails)}: exit {exit}"


class GoalMachine:
    """The navigator's state: STOPPED or running one goal."""

    def __init__(self, params: Params, wheels: Wheelbase, area: Field | None = None, gated: bool = True) -> None:
        self.params, self.wheels = params, wheels
        self.gated = gated  # an uncertain pose refuses and aborts goals (a VPS runs); else it is only reported
        self.area = area or Field(enabled=False)
        self.state = STOPPED
        self.goal_id = 0  # id of the newest goal
        self.goal: Goal | None = None  # the newest goal (kept after it ends)
        self.result: str | None = None  # result of the newest goal; None while it runs
        self.exit: str | None = None  # why the newest goal's move ended; None while it runs
        self.message = ""
        self.pose: PoseSample | None = None  # newest pose
        self._cmd = (0.0, 0.0)  # (v [m/s], omega [rad/s]) last commanded
        self._rate = (0.0, 0.0)  # (v [m/s], omega [rad/s]) the commands through a first-order lag of stop_lead
        self._coast: float | None = None  # [s] pose t until which a chained goal's last command is held
        self._run: _Run | None = None

    @property
    def active(self) -> bool:
        """Whether a goal is running."""
        return self._run is not None

    def refusal(self, now: float) -> str | None:
        """Why no goal can start now (no pose, stale pose, uncertain pose), or None."""
        if self.pose is None:
            return "no pose yet: is the localizer running?"
        if now - self.pose.t > self.params.stale_after:
            return f"pose stale: the newest is {now - self.pose.t:.2f} s old"
        doubt = self.uncertain() if self.gated else None
        if doubt is not None:
            return f"{doubt} (no VPS fix yet or for long: wait for one, or set the pose)"
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
        preempted = self._end(CANCELLED, f"preempted by goal {self.goal_id + 1}", stop=False, exit=exits.CANCELLED)
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
        run = self._run = _Run(goal, now, pose, beyond, Hold(p.settle_time), Hold(p.big_time), deadline)
        if goal.state == TURNING_TO_HEADING:
            err = wrap_angle(goal.heading - pose.theta)
            run.forced = goal.direction != 0 and abs(err) > goal.tolerance  # told its way, and not there already
            run.way = float(goal.direction) if run.forced else math.copysign(1.0, err)
        if goal.points:
            run.rest = path_rest(goal.points)
            self._aim(run, pose)
        cmd = self._step(run, pose)  # feedback and progress from the start
        if cmd is None and run.exit != exits.CHAINED:  # already there (a chained goal already there ends on the next pose)
            self._stop(run, pose)
        run.best, run.best_t = run.progress, now
        return preempted

    def cancel(self, message: str) -> End | None:
        """Cancel the running goal (stop, lease...), and a chained goal's held command; None if there is no goal."""
        self._coast = None
        return self._end(CANCELLED, message, stop=True, exit=exits.CANCELLED)

    def abort(self, message: str, exit: str = exits.ABORTED) -> End | None:
        """Abort the running goal, and a chained goal's held command; None if there is no goal."""
        self._coast = None
        return self._end(ABORTED, message, stop=True, exit=exit)

    @property
    def coasting(self) -> bool:
        """Whether a chained goal's last command is still held (no goal runs)."""
        return self._coast is not None

    def reset(self, message: str) -> End | None:
        """Time started again (sim restart): abort the goal and forget the pose."""
        end = self.abort(message)
        self.pose = None
        return end

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
            cmd = None if run.exit == exits.CHAINED else self._step(run, pose)
            if cmd is not None:
                self._cmd = controllers.limit(run.sign * cmd[0], cmd[1], self.params.max_turn_speed, self.wheels)
                return self._cmd, None
            if run.exit == exits.CHAINED:
                return self._chained(run, pose)
            self._stop(run, pose)
        assert run.settle_from is not None and run.exit is not None  # stopped
        resting = pose.t - run.settle_from
        # While the wheels slip the position waits for the fixes: a robot held short by a wall has not "arrived".
        waiting = pose.slipping and resting < self.params.rest_time + self.params.slip_wait
        if resting >= self.params.rest_time and not waiting:
            result, message = verdict(run.goal, run.origin, pose, run.exit)
            if result != SUCCEEDED and run.slipped:
                message += SLIPPED
            if result == SUCCEEDED or not self._retry(run, pose):
                return (0.0, 0.0), self._end(result, message, stop=True, exit=run.exit)
            return self.on_pose(self.pose)
        return (0.0, 0.0), None

    def check(self, now: float) -> End | None:
        """Periodic checks: abort on a stale pose or no progress for too long; stop at the time-out."""
        run, p, pose = self._run, self.params, self.pose
        if run is None or pose is None:  # a goal runs only from a pose
            return None
        if now - pose.t > p.stale_after:
            return self.abort(f"pose stale: none for {now - pose.t:.2f} s")
        doubt = self.uncertain() if self.gated else None
        if doubt is not None:
            return self.abort(doubt)
        if run.goal.state == MOVING_STRAIGHT and run.goal.distance is None and now - run.start_t >= p.straight_max_time:
            message = f"move_straight without a distance stops after straight_max_time = {p.straight_max_time:g} s"
            return self.abort(message, exits.TIMEOUT)
        if run.settle_from is None and now >= run.deadline:
            run.exit = exits.TIMEOUT
            self._stop(run, pose)  # zero from the next pose on, then the error is re-checked
        angular = run.goal.state == TURNING_TO_HEADING or run.turning or run.facing
        step = p.progress_angle if angular else p.progress_distance
        if run.settle_from is not None or run.best is None or run.progress >= run.best + step:
            run.best, run.best_t = run.progress, now
        elif now - run.best_t > p.progress_timeout:
            return self.abort(f"no progress for {now - run.best_t:.1f} s{SLIPPED if run.slipped else ''}", exits.STALLED)
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
        self.state, self.result, self.exit, self.message = STOPPED, result, exit, message
        return End(self.goal_id, result, message, stop, exit)

    def _chained(self, run: _Run, pose: PoseSample) -> tuple[tuple[float, float], End | None]:
        """A chained goal crossed its exit line: it succeeds at once, its last command held for chain_time."""
        self._coast = pose.t + self.params.chain_time
        dist, turn = final_error(run.goal, run.origin, pose)
        off = f"{math.degrees(turn):.1f} deg" if run.goal.state == TURNING_TO_HEADING else f"{dist * 100:.1f} cm"
        return self._cmd, self._end(SUCCEEDED, f"chained {off} from the target, at speed", stop=False, exit=exits.CHAINED)

    def _held(self, t: float) -> tuple[float, float] | None:
        """No goal runs: a chained goal's last command until chain_time has passed, then zero once; else None."""
        if self._coast is None:
            return None
        if t >= self._coast:
            self._coast, self._cmd = None, (0.0, 0.0)
        return self._cmd

    def _crossed(self, run: _Run, along: float) -> bool:
        """Whether a chained goal, `along` before its target's line now, has just crossed early_exit_range before it.

        A point or a turn that starts within early_exit_range of its target ends at once; a pose does not (the robot
        may start past its target's line, and come round to cross it).
        """
        before, run.along = run.along, along
        start = before is None and run.goal.state != MOVING_TO_POSE
        if along <= run.goal.early_exit_range and (start or (before is not None and before > run.goal.early_exit_range)):
            run.exit = exits.CHAINED
            return True
        return False

    def _stop(self, run: _Run, pose: PoseSample) -> None:
        """The move ends at `pose` (run.exit says why): zero from now on, the error re-checked after rest_time."""
        run.settle_from, run.held, self._cmd = pose.t, pose.slipping, (0.0, 0.0)
        run.slipped = run.slipped or pose.slipping
        run.exit = run.exit or exits.WITHIN_TOLERANCE
        run.remaining = 0.0 if run.remaining is not None else None

    def _retry(self, run: _Run, pose: PoseSample) -> bool:
        """Move again after a re-check over the tolerance (a late fix moved the pose), up to `retries` times.

        Only a move that ended at its target (within_tolerance, passed) is corrected, a path from its last point:
        straight on (forwards or back) when the point lies near the heading line (within FACE_OFF_LINE of the
        tolerance, straight on then ends within it, or within what the estimate's noise explains); else first
        turning in place to face it (or to back onto it, whichever turn is smaller). Not a move that stopped with
        its wheels slipping: a wall or a robot held it, and moving again would push into it again.
        """
        if run.exit not in (exits.WITHIN_TOLERANCE, exits.PASSED) or run.retries >= self.params.retries or run.held:
            return False
        if run.goal.state == MOVING_STRAIGHT:
            return False
        run.retries += 1
        run.settle_from, run.exit, run.turning = None, None, False
        if run.goal.points:
            run.index = len(run.goal.points) - 1
            self._aim(run, pose)
            target = _aimed(run)
            run.locked = True
            off_line = FACE_OFF_LINE * run.goal.tolerance + NOISE_SIGMAS * pose.sigma_xy  # [m]
            run.facing = abs(_lateral(pose.x, pose.y, pose.theta, target.x, target.y)) > off_line
        run.small.reset()
        run.big.reset()
        return True

    def _aim(self, run: _Run, pose: PoseSample) -> None:
        """Target the current point: a fresh controller, and the old progress invalidated."""
        x, y = run.goal.points[run.index]
        if run.goal.state == MOVING_TO_POSE and run.index + 1 == len(run.goal.points):  # a planned detour's corners: points
            run.target = Target(x, y, run.goal.heading, run.goal.speed, lead=run.goal.lead)
            run.controller = controllers.make(self.params.pose_controller)
        else:
            reverse_ok = self.params.controller == "polar" and run.sign > 0.0  # backwards was asked for: no turning round
            run.target = controllers.make_target(pose, x, y, run.goal.speed, reverse_ok)
            run.controller = controllers.make(self.params.controller)
        run.best = None
        run.small.reset()
        run.big.reset()

    def _step(self, run: _Run, pose: PoseSample) -> tuple[float, float] | None:
        """The command for this pose; None once the move ends (run.exit says why). Updates feedback and progress."""
        goal, p = run.goal, self.params
        if goal.state == MOVING_STRAIGHT:
            return self._step_straight(run, pose)
        if goal.state == TURNING_TO_HEADING:
            cmd = (
                self._chained_turn(run, pose)
                if goal.min_speed > 0.0
                else self._step_turn(run, pose, goal.heading, goal.tolerance, goal.speed)
            )
            if cmd is not None and goal.pivot:  # a swing: the still wheel's speed, v -/+ omega * track / 2, is zero
                cmd = (goal.pivot * cmd[1] * self.wheels.track / 2.0, cmd[1])
            if goal.min_speed > 0.0:
                return cmd
        else:
            cmd = self._step_points(run, pose)
            if run.index + 1 < len(goal.points):
                return cmd
        if cmd is None:
            return None
        dist, turn = final_error(goal, run.origin, pose)
        # Both bands are followed on every pose, so that each keeps its own time held (not while facing a point).
        holding = not run.facing
        settled = run.small.update(pose.t, holding and dist <= p.settle_error and turn <= p.settle_heading_error)
        near = run.big.update(pose.t, holding and dist <= p.big_error and turn <= p.big_heading_error)
        if settled or near:
            run.exit = exits.SETTLED if settled else exits.BIG_ERROR
            return None
        return cmd

    def _point_tolerance(self, run: _Run, i: int) -> float:
        goal = run.goal
        if goal.point_tolerances:
            return goal.point_tolerances[i]
        return goal.tolerance if i + 1 == len(goal.points) else self.params.waypoint_tolerance

    def _step_points(self, run: _Run, pose: PoseSample) -> tuple[float, float] | None:
        p, goal, v = self.params, run.goal, run.sign * self._rate[0]
        px = pose.x + v * math.cos(pose.theta) * p.stop_lead  # [m] position predicted at the stop
        py = pose.y + v * math.sin(pose.theta) * p.stop_lead
        last = len(goal.points) - 1
        for _ in range(MAX_SWITCHES):  # intermediate points: passed once within their tolerance
            target = _aimed(run)
            near = min(math.hypot(target.x - pose.x, target.y - pose.y), math.hypot(target.x - px, target.y - py))
            if run.index == last or near > self._point_tolerance(run, run.index):
                break
            run.index += 1  # switch: the old target's distance and progress no longer count
            self._aim(run, pose)
        target = _aimed(run)
        dist = math.hypot(target.x - pose.x, target.y - pose.y)
        start = goal.points[run.index - 1] if run.index else (run.origin.x, run.origin.y)
        seg_heading = math.atan2(target.y - start[1], target.x - start[0])
        bearing = wrap_angle(math.atan2(target.y - pose.y, target.x - pose.x) - pose.theta)
        run.remaining = dist + run.rest[run.index]
        run.heading_error = wrap_angle(bearing + math.pi) if target.reverse else bearing
        run.cross_track = _lateral(start[0], start[1], seg_heading, pose.x, pose.y)
        assert run.controller is not None  # made with the target
        if run.index < last:
            run.progress = -dist
            return self._through(run, pose, target, dist)
        if goal.min_speed > 0.0:
            approach = goal.heading if goal.state == MOVING_TO_POSE else seg_heading
            along = (target.x - pose.x) * math.cos(approach) + (target.y - pose.y) * math.sin(approach)  # [m] before its line
            if goal.state != MOVING_TO_POSE or dist > p.lock_distance or self._passing(run, pose, along):
                run.progress = -dist
                return self._chained_point(run, pose, target, along)
            run.goal = goal = replace(goal, min_speed=0.0)  # close, and it cannot pass through its pose at speed: it ends unchained
        if run.turning:
            return self._step_turn(run, pose, goal.heading, goal.heading_tolerance, p.turn_speed)
        run.progress = -dist
        if dist <= goal.tolerance and math.hypot(target.x - px, target.y - py) <= goal.tolerance:
            if goal.state != MOVING_TO_POSE:
                run.exit = exits.WITHIN_TOLERANCE
                return None
            run.turning, run.best = True, None  # at the point: turn in place to the heading
            return self._step_turn(run, pose, goal.heading, goal.heading_tolerance, p.turn_speed)
        if run.facing:
            cmd = self._face(run, pose, bearing, dist)
            if cmd is not None:
                return cmd
        lateral = dist * math.sin(bearing)  # [m] of the point off the robot's heading line
        if dist > 2.0 * p.lock_distance:
            run.locked = False
        elif dist <= p.lock_distance and abs(lateral) <= goal.tolerance / 2.0:
            run.locked = True
        if run.locked:
            return self._locked(run, pose, target)
        v, omega = run.controller(pose, target, p)
        if run.index > 0 and dist > p.lock_distance and math.cos(run.heading_error or 0.0) > 0.0:
            # A path's last leg: the turn onto it blends in, as at the points before.
            v = math.copysign(max(abs(v), p.through_speed), -1.0 if target.reverse else 1.0)
        return v, omega

    def _passing(self, run: _Run, pose: PoseSample, along: float) -> bool:
        """Whether a chained pose, close to its point, passes through it at speed: before its line and facing within 90 deg
        of its heading, or just across the line. Else (past the line, or facing away) it ends as an unchained move."""
        eer = run.goal.early_exit_range
        facing = abs(wrap_angle(run.goal.heading - pose.theta)) <= math.pi / 2
        return (along > eer and facing) or (run.along is not None and run.along > eer)

    def _chained_point(self, run: _Run, pose: PoseSample, target: Target, along: float) -> tuple[float, float] | None:
        """A chained goal's final point, `along` [m] before the line across its approach (a pose: its heading): steered
        by the controller, no slower than min_speed while it drives toward the point, until the robot crosses that line
        early_exit_range before the point.

        Within lock_distance it no longer turns toward the point (a pose: it steers to its heading), as LemLib once
        `close`, and brakes to cross the line at min_speed: the next goal starts from a steady command.
        """
        p, goal = self.params, run.goal
        if self._crossed(run, along):
            return None
        ahead = -1.0 if target.reverse else 1.0
        if math.hypot(target.x - pose.x, target.y - pose.y) <= p.lock_distance:
            omega = p.prop_heading_gain * wrap_angle(goal.heading - pose.theta) if goal.state == MOVING_TO_POSE else 0.0
            return ahead * profile_speed(along - goal.early_exit_range, p.decel, goal.min_speed, goal.speed), omega
        assert run.controller is not None  # made with the target
        v, omega = run.controller(pose, target, p)
        if v * ahead > 0.0:  # a controller that has slowed to turn in place first is not pushed on
            v = ahead * min(max(abs(v), goal.min_speed), goal.speed)
        return v, omega

    def _chained_turn(self, run: _Run, pose: PoseSample) -> tuple[float, float] | None:
        """A chained turn: no slower than min_speed, until the heading is within early_exit_range (or passed)."""
        goal = run.goal
        err = self._turn_error(run, goal.heading, pose.theta)
        run.heading_error, run.progress, run.remaining = err, -abs(err), abs(err)
        if self._crossed(run, err * run.way):
            return None
        return 0.0, run.way * profile_speed(err * run.way - goal.early_exit_range, self.params.turn_decel, goal.min_speed, goal.speed)

    @staticmethod
    def _turn_error(run: _Run, heading: float, theta: float) -> float:
        """[rad] `heading` - `theta`, the shorter way; a turn told its direction: that way round (up to a full turn),
        until it comes within RELEASE of the heading."""
        err = wrap_angle(heading - theta)
        if run.forced:
            if err * run.way < 0.0:
                err += run.way * math.tau
            run.forced = abs(err) >= RELEASE
        return err

    def _face(self, run: _Run, pose: PoseSample, bearing: float, dist: float) -> tuple[float, float] | None:
        """A correction's turn in place until the point lies within half the tolerance of the heading line; None when done."""
        p = self.params
        back = abs(bearing) > math.pi / 2.0  # backing onto the point is the smaller turn
        heading = wrap_angle(pose.theta + bearing + (math.pi if back else 0.0))
        tolerance = math.atan2(run.goal.tolerance / 2.0, max(dist, run.goal.tolerance))  # [rad]
        cmd = self._step_turn(run, pose, heading, tolerance, p.turn_speed)
        if cmd is None:
            run.facing, run.exit, run.best = False, None, None  # faced: drive straight onto it
        return cmd

    def _locked(self, run: _Run, pose: PoseSample, target: Target) -> tuple[float, float] | None:
        """Close to the final point: drive straight on, not turning toward the point, braking into it abeam."""
        p, goal = self.params, run.goal
        along = (target.x - pose.x) * math.cos(pose.theta) + (target.y - pose.y) * math.sin(pose.theta)  # [m]
        ahead = along - run.sign * self._rate[0] * p.stop_lead  # [m] predicted along-track error at the stop
        if ahead * (run.sign * self._cmd[0] or along) <= 0.0:  # the stop is predicted at or past the point abeam: stop now
            lateral = _lateral(pose.x, pose.y, pose.theta, target.x, target.y)  # [m]
            inside = math.hypot(ahead, lateral) <= goal.tolerance  # the predicted stop
            if goal.state != MOVING_TO_POSE:
                run.exit = exits.WITHIN_TOLERANCE if inside else exits.PASSED
                return None
            run.exit = None if inside else exits.PASSED
            run.turning, run.best = True, None  # as close as it gets: the heading is still to be reached
            return self._step_turn(run, pose, goal.heading, goal.heading_tolerance, p.turn_speed)
        # Braking to reach the tolerance's edge at the speed whose coast ends on the point: the stop there lands close.
        edge = goal.tolerance / p.stop_lead if p.stop_lead > 0.0 else goal.speed  # [m/s]
        speed = math.sqrt(edge**2 + 2.0 * p.decel * max(abs(along) - goal.tolerance, 0.0))
        return math.copysign(max(p.min_speed, min(speed, goal.speed)), ahead), 0.0

    def _through(self, run: _Run, pose: PoseSample, target: Target, dist: float) -> tuple[float, float]:
        """An intermediate point: steer with the controller, keeping a speed the next turn can be taken at."""
        p, goal = self.params, run.goal
        assert run.controller is not None and run.heading_error is not None
        _, omega = run.controller(pose, target, p)
        here, after = goal.points[run.index], goal.points[run.index + 1]
        corner = abs(wrap_angle(math.atan2(after[1] - here[1], after[0] - here[0]) - math.atan2(target.y - pose.y, target.x - pose.x)))
        v_corner = max(p.through_speed, abs(goal.speed) * max(0.0, math.cos(corner)))  # [m/s] at the point
        cap = min(abs(goal.speed), math.sqrt(v_corner**2 + 2.0 * p.decel * dist))
        ahead = math.cos(run.heading_error)  # a point behind (missed) is turned to in place
        v = max(p.through_speed if ahead > 0.0 else 0.0, cap * max(0.0, ahead))
        return (-v if target.reverse else v), omega

    def _step_turn(self, run: _Run, pose: PoseSample, heading: float, tolerance: float, speed: float) -> tuple[float, float] | None:
        p = self.params
        err = self._turn_error(run, heading, pose.theta)
        rate = self._rate[1]  # [rad/s]
        ahead = err - rate * p.stop_lead  # [rad] predicted error at the stop
        run.heading_error, run.progress = err, -abs(err)
        if run.goal.state == TURNING_TO_HEADING:
            run.remaining = abs(err)
        if abs(err) <= tolerance and abs(ahead) <= tolerance:
            run.exit = run.exit or exits.WITHIN_TOLERANCE  # a move_to_pose that passed its point says so
            return None
        omega = turn_command(err, rate, speed, tolerance, p.turn_decel, p.min_turn_speed, p.stop_lead)
        if omega is None:  # the coast is predicted to reach the heading: within it, or past it
            run.exit = run.exit or (exits.WITHIN_TOLERANCE if abs(ahead) <= tolerance else exits.PASSED)
            return None
        return 0.0, omega

    def _step_straight(self, run: _Run, pose: PoseSample) -> tuple[float, float] | None:
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
        ahead = left - abs(self._rate[0]) * p.stop_lead  # [m] predicted left after the lead
        if ahead <= 0.0:
            run.exit = exits.WITHIN_TOLERANCE if ahead >= -goal.tolerance else exits.PASSED
            return None
        return sign * profile_speed(ahead, p.decel, p.min_speed, abs(goal.speed)), omega
