"""The command for each pose of a running goal: toward its points (through the intermediate ones, locked straight
on near the last, chained at speed), its heading, or along a straight line; and when the move ends (run.exit).
Pure: poses come in as arguments."""

from __future__ import annotations

import math
from dataclasses import replace

from zenav.common.contract import Exit, State
from zenav.common.geometry import wrap_angle
from zenav.services.navigator import controllers
from zenav.services.navigator.controllers import PoseSample, Target, Wheelbase
from zenav.services.navigator.goal import Run, aimed, final_error, left_of
from zenav.services.navigator.params import Params
from zenav.services.navigator.turning import profile_speed, turn_command

MAX_SWITCHES = 256  # path points passed on one pose at most (bunched points: the rest on the next poses)
RELEASE = math.pi / 4  # [rad] a turn told its direction turns the shorter way once this close (an overshoot is no full turn)


class Steering:
    """How GoalMachine steers a run (a part of it: the state is the machine's)."""

    params: Params
    wheels: Wheelbase
    _cmd: tuple[float, float]  # (v [m/s], omega [rad/s]) last commanded
    _rate: tuple[float, float]  # (v [m/s], omega [rad/s]) the commands through a first-order lag of stop_lead

    def _crossed(self, run: Run, along: float) -> bool:
        """Whether a chained goal, `along` before its target's line now, has just crossed early_exit_range before it.

        A point or a turn that starts within early_exit_range of its target ends at once; a pose does not (the robot
        may start past its target's line, and come round to cross it).
        """
        before, run.along = run.along, along
        start = before is None and run.goal.state != State.MOVING_TO_POSE
        if along <= run.goal.early_exit_range and (start or (before is not None and before > run.goal.early_exit_range)):
            run.exit = Exit.CHAINED
            return True
        return False

    def _aim(self, run: Run, pose: PoseSample) -> None:
        """Target the current point: a fresh controller, and the old progress invalidated."""
        x, y = run.goal.points[run.index]
        if run.goal.state == State.MOVING_TO_POSE and run.index + 1 == len(run.goal.points):  # a planned detour's corners: points
            run.target = Target(x, y, run.goal.heading, run.goal.speed, lead=run.goal.lead)
            run.controller = controllers.make(self.params.pose_controller)
        else:
            reverse_ok = self.params.controller == "polar" and run.sign > 0.0  # backwards was asked for: no turning round
            run.target = controllers.make_target(pose, x, y, run.goal.speed, reverse_ok)
            run.controller = controllers.make(self.params.controller)
        run.best = None
        run.small.reset()
        run.big.reset()

    def _step(self, run: Run, pose: PoseSample) -> tuple[float, float] | None:
        """The command for this pose; None once the move ends (run.exit says why). Updates feedback and progress."""
        goal, p = run.goal, self.params
        if goal.state == State.MOVING_STRAIGHT:
            return self._step_straight(run, pose)
        if goal.state == State.TURNING_TO_HEADING:
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
            run.exit = Exit.SETTLED if settled else Exit.BIG_ERROR
            return None
        return cmd

    def _point_tolerance(self, run: Run, i: int) -> float:
        goal = run.goal
        if goal.point_tolerances:
            return goal.point_tolerances[i]
        return goal.tolerance if i + 1 == len(goal.points) else self.params.waypoint_tolerance

    def _step_points(self, run: Run, pose: PoseSample) -> tuple[float, float] | None:
        p, goal, v = self.params, run.goal, run.sign * self._rate[0]
        px = pose.x + v * math.cos(pose.theta) * p.stop_lead  # [m] position predicted at the stop
        py = pose.y + v * math.sin(pose.theta) * p.stop_lead
        last = len(goal.points) - 1
        for _ in range(MAX_SWITCHES):  # intermediate points: passed once within their tolerance
            target = aimed(run)
            near = min(math.hypot(target.x - pose.x, target.y - pose.y), math.hypot(target.x - px, target.y - py))
            if run.index == last or near > self._point_tolerance(run, run.index):
                break
            run.index += 1  # switch: the old target's distance and progress no longer count
            self._aim(run, pose)
        target = aimed(run)
        dist = math.hypot(target.x - pose.x, target.y - pose.y)
        start = goal.points[run.index - 1] if run.index else (run.origin.x, run.origin.y)
        seg_heading = math.atan2(target.y - start[1], target.x - start[0])
        bearing = wrap_angle(math.atan2(target.y - pose.y, target.x - pose.x) - pose.theta)
        run.remaining = dist + run.rest[run.index]
        run.heading_error = wrap_angle(bearing + math.pi) if target.reverse else bearing
        run.cross_track = left_of(start[0], start[1], seg_heading, pose.x, pose.y)
        assert run.controller is not None  # made with the target
        if run.index < last:
            run.progress = -dist
            return self._through(run, pose, target, dist)
        if goal.min_speed > 0.0:
            approach = goal.heading if goal.state == State.MOVING_TO_POSE else seg_heading
            along = (target.x - pose.x) * math.cos(approach) + (target.y - pose.y) * math.sin(approach)  # [m] before its line
            if goal.state != State.MOVING_TO_POSE or dist > p.lock_distance or self._passing(run, pose, along):
                run.progress = -dist
                return self._chained_point(run, pose, target, along)
            run.goal = goal = replace(goal, min_speed=0.0)  # close, and it cannot pass through its pose at speed: it ends unchained
        if run.turning:
            return self._step_turn(run, pose, goal.heading, goal.heading_tolerance, p.turn_speed)
        run.progress = -dist
        if dist <= goal.tolerance and math.hypot(target.x - px, target.y - py) <= goal.tolerance:
            if goal.state != State.MOVING_TO_POSE:
                run.exit = Exit.WITHIN_TOLERANCE
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

    def _passing(self, run: Run, pose: PoseSample, along: float) -> bool:
        """Whether a chained pose, close to its point, passes through it at speed: before its line and facing within 90 deg
        of its heading, or just across the line. Else (past the line, or facing away) it ends as an unchained move."""
        eer = run.goal.early_exit_range
        facing = abs(wrap_angle(run.goal.heading - pose.theta)) <= math.pi / 2
        return (along > eer and facing) or (run.along is not None and run.along > eer)

    def _chained_point(self, run: Run, pose: PoseSample, target: Target, along: float) -> tuple[float, float] | None:
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
            omega = p.prop_heading_gain * wrap_angle(goal.heading - pose.theta) if goal.state == State.MOVING_TO_POSE else 0.0
            return ahead * profile_speed(along - goal.early_exit_range, p.decel, goal.min_speed, goal.speed), omega
        assert run.controller is not None  # made with the target
        v, omega = run.controller(pose, target, p)
        if v * ahead > 0.0:  # a controller that has slowed to turn in place first is not pushed on
            v = ahead * min(max(abs(v), goal.min_speed), goal.speed)
        return v, omega

    def _chained_turn(self, run: Run, pose: PoseSample) -> tuple[float, float] | None:
        """A chained turn: no slower than min_speed, until the heading is within early_exit_range (or passed)."""
        goal = run.goal
        err = self._turn_error(run, goal.heading, pose.theta)
        run.heading_error, run.progress, run.remaining = err, -abs(err), abs(err)
        if self._crossed(run, err * run.way):
            return None
        return 0.0, run.way * profile_speed(err * run.way - goal.early_exit_range, self.params.turn_decel, goal.min_speed, goal.speed)

    @staticmethod
    def _turn_error(run: Run, heading: float, theta: float) -> float:
        """[rad] `heading` - `theta`, the shorter way; a turn told its direction: that way round (up to a full turn),
        until it comes within RELEASE of the heading."""
        err = wrap_angle(heading - theta)
        if run.forced:
            if err * run.way < 0.0:
                err += run.way * math.tau
            run.forced = abs(err) >= RELEASE
        return err

    def _face(self, run: Run, pose: PoseSample, bearing: float, dist: float) -> tuple[float, float] | None:
        """A correction's turn in place until the point lies within half the tolerance of the heading line; None when done."""
        p = self.params
        back = abs(bearing) > math.pi / 2.0  # backing onto the point is the smaller turn
        heading = wrap_angle(pose.theta + bearing + (math.pi if back else 0.0))
        tolerance = math.atan2(run.goal.tolerance / 2.0, max(dist, run.goal.tolerance))  # [rad]
        cmd = self._step_turn(run, pose, heading, tolerance, p.turn_speed)
        if cmd is None:
            run.facing, run.exit, run.best = False, None, None  # faced: drive straight onto it
        return cmd

    def _locked(self, run: Run, pose: PoseSample, target: Target) -> tuple[float, float] | None:
        """Close to the final point: drive straight on, not turning toward the point, braking into it abeam."""
        p, goal = self.params, run.goal
        along = (target.x - pose.x) * math.cos(pose.theta) + (target.y - pose.y) * math.sin(pose.theta)  # [m]
        ahead = along - run.sign * self._rate[0] * p.stop_lead  # [m] predicted along-track error at the stop
        if ahead * (run.sign * self._cmd[0] or along) <= 0.0:  # the stop is predicted at or past the point abeam: stop now
            lateral = left_of(pose.x, pose.y, pose.theta, target.x, target.y)  # [m]
            inside = math.hypot(ahead, lateral) <= goal.tolerance  # the predicted stop
            if goal.state != State.MOVING_TO_POSE:
                run.exit = Exit.WITHIN_TOLERANCE if inside else Exit.PASSED
                return None
            run.exit = None if inside else Exit.PASSED
            run.turning, run.best = True, None  # as close as it gets: the heading is still to be reached
            return self._step_turn(run, pose, goal.heading, goal.heading_tolerance, p.turn_speed)
        # Braking to reach the tolerance's edge at the speed whose coast ends on the point: the stop there lands close.
        edge = goal.tolerance / p.stop_lead if p.stop_lead > 0.0 else goal.speed  # [m/s]
        speed = math.sqrt(edge**2 + 2.0 * p.decel * max(abs(along) - goal.tolerance, 0.0))
        return math.copysign(max(p.crawl_speed, min(speed, goal.speed)), ahead), 0.0

    def _through(self, run: Run, pose: PoseSample, target: Target, dist: float) -> tuple[float, float]:
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

    def _step_turn(self, run: Run, pose: PoseSample, heading: float, tolerance: float, speed: float) -> tuple[float, float] | None:
        p = self.params
        err = self._turn_error(run, heading, pose.theta)
        rate = self._rate[1]  # [rad/s]
        ahead = err - rate * p.stop_lead  # [rad] predicted error at the stop
        run.heading_error, run.progress = err, -abs(err)
        if run.goal.state == State.TURNING_TO_HEADING:
            run.remaining = abs(err)
        if abs(err) <= tolerance and abs(ahead) <= tolerance:
            run.exit = run.exit or Exit.WITHIN_TOLERANCE  # a move_to_pose that passed its point says so
            return None
        omega = turn_command(err, rate, speed, tolerance, p.turn_decel, p.min_turn_speed, p.stop_lead)
        if omega is None:  # the coast is predicted to reach the heading: within it, or past it
            run.exit = run.exit or (Exit.WITHIN_TOLERANCE if abs(ahead) <= tolerance else Exit.PASSED)
            return None
        return 0.0, omega

    def _step_straight(self, run: Run, pose: PoseSample) -> tuple[float, float] | None:
        p, goal, o = self.params, run.goal, run.origin
        sign = math.copysign(1.0, goal.speed)
        travelled = sign * ((pose.x - o.x) * math.cos(o.theta) + (pose.y - o.y) * math.sin(o.theta))
        lateral = left_of(o.x, o.y, o.theta, pose.x, pose.y)
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
            run.exit = Exit.WITHIN_TOLERANCE if ahead >= -goal.tolerance else Exit.PASSED
            return None
        return sign * profile_speed(ahead, p.decel, p.crawl_speed, abs(goal.speed)), omega
