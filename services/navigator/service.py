"""The navigator service: nav/* goals in, cmd_vel per pose while a goal runs, nav/state out.

Goal queries reply at once with the goal id, or with `wait` when the goal ends.
A `lease` names a liveliness token the caller holds: the goal starts once the token
is seen alive (the request is answered `unavailable` if it is not seen within
`lease_grace`), and is aborted, with the robot stopped, when the token disappears.
"""
from __future__ import annotations

import itertools
import math
import queue
from dataclasses import dataclass
from typing import Any, Optional

from zenav.common import messages as m
from zenav.common.bus import Bus, Handle, Query
from zenav.common.clock import Clock
from zenav.common.config import ConfigError, Settings
from zenav.common.geometry import wrap_angle
from zenav.common.runtime import QueryError, Service, on_liveliness, publish, query, reply_error, reply_ok, subscribe, timer
from zenav.services.navigator import goals
from zenav.services.navigator.controllers import PoseSample, Wheelbase, check_polar_gains, sigmas
from zenav.services.navigator.goals import End, Goal, GoalMachine, Refused
from zenav.services.navigator.params import Params


@dataclass
class _Request:
    """A goal request, resolved, until it starts."""

    goal: Goal
    info: dict[str, Any]  # the `goal` map of nav/state
    wait: bool
    q: Query
    lease: Optional[str] = None
    watch: Optional[Handle] = None
    watch_id: int = 0
    deadline: float = 0.0  # [s] clock time the lease must be seen by
    goal_id: int = 0  # once started


class Navigator(Service):
    """Drives the robot to goals given over Zenoh queries, from the localizer's pose."""

    name = "navigator"
    config_type = Params

    def __init__(self, settings: Settings, bus: Bus, clock: Clock) -> None:
        super().__init__(settings, bus, clock)
        cfg: Params = self.cfg
        try:
            check_polar_gains(cfg.k_rho, cfg.k_alpha, cfg.k_beta)
        except ValueError as e:
            raise ConfigError(f"config [navigator]: {e}") from None
        self.check_period, self.state_period = cfg.check_period, cfg.state_period  # read by @timer
        r = settings.robot
        self.machine = GoalMachine(cfg, Wheelbase(r.track_width, r.wheel_radius, r.max_wheel_speed))
        self._info: Optional[dict[str, Any]] = None  # the newest goal, as nav/state shows it
        self._waiters: dict[int, Query] = {}  # goal id -> query answered when it ends
        self._speeds: dict[int, float] = {}  # goal id -> speed used, for the wait reply
        self._running: Optional[_Request] = None  # the running goal's request (its lease)
        self._pending: Optional[_Request] = None  # a goal waiting to see its lease token
        self._lease_events: queue.SimpleQueue = queue.SimpleQueue()  # (watch id, alive) from bus threads
        self._watch_ids = itertools.count(1)
        self._shown: Optional[tuple] = None  # (state, goal_id, result) last published

    # ------------------------------------------------------------ inputs
    @subscribe("pose")
    @publish("cmd_vel")
    def on_pose(self, msg: m.Pose) -> Optional[m.CmdVel]:
        """Run the goal on each pose: the command acts on (and carries the t of) this pose."""
        last = self.machine.pose
        if last is not None and msg.t < last.t:
            self.count("dropped_stale")
            self.warn("pose_order", f"dropped a pose out of order (t {msg.t:.3f} < {last.t:.3f})")
            return None
        self._poll_leases()
        sample = PoseSample(msg.t, msg.x, msg.y, wrap_angle(msg.theta), msg.v, msg.omega, *sigmas(msg.cov))
        cmd, end = self.machine.on_pose(sample)
        if end is not None:
            self._ended(end, zero=False)  # the zero goes out below, with this pose's t
        self._show_changes()
        return None if cmd is None else m.CmdVel(t=msg.t, v=cmd[0], omega=cmd[1])

    @timer("check_period")
    def check(self, now: float) -> None:
        """Lease events, the lease grace, stale pose and progress checks."""
        self._poll_leases()
        p = self._pending
        if p is not None and now >= p.deadline:
            self._drop_pending(f"lease {p.lease} is not alive")
        end = self.machine.check(now)
        if end is not None:
            self._ended(end)
        self._show_changes()

    @on_liveliness("motor")
    def motor_presence(self, alive: bool) -> None:
        """The motor service went: the goal cannot go on (a restarted motor must not resume it)."""
        self._needed_gone("motor", alive)

    @on_liveliness("localizer")
    def localizer_presence(self, alive: bool) -> None:
        """The localizer went: abort at once rather than when its pose turns stale."""
        self._needed_gone("localizer", alive)

    @on_liveliness("odometry")
    def odometry_presence(self, alive: bool) -> None:
        """The odometry went: no more poses will come; abort at once."""
        self._needed_gone("odometry", alive)

    @timer("state_period")
    @publish("nav/state")
    def state_tick(self, now: float) -> m.NavState:
        """nav/state at 5 Hz, between changes."""
        return self._state(now)

    # ------------------------------------------------------------ queries
    @query("nav/move_to_point")
    def move_to_point(self, req: m.MoveToPoint, q: Query) -> None:
        """Drive to (x, y) with the configured point tracker."""
        speed, tol = self._speed(req.speed), req.tolerance or self.cfg.tolerance
        goal = Goal(goals.MOVING_TO_POINT, points=((req.x, req.y),), speed=speed, tolerance=tol)
        self._request(goal, req, q, {"type": "move_to_point", "x": req.x, "y": req.y, "speed": speed, "tolerance": tol})

    @query("nav/turn_to_heading")
    def turn_to_heading(self, req: m.TurnToHeading, q: Query) -> None:
        """Turn in place to a heading."""
        self._turn(wrap_angle(req.heading), req, q, {"type": "turn_to_heading", "heading": req.heading})

    @query("nav/turn_to_point")
    def turn_to_point(self, req: m.TurnToPoint, q: Query) -> None:
        """Turn in place to face (x, y), the heading taken from the pose at the start."""
        pose = self._pose_or_unavailable()
        if math.hypot(req.x - pose.x, req.y - pose.y) < 1e-3:
            raise QueryError("invalid_argument", "x, y: the point is where the robot is, it has no heading")
        heading = math.atan2(req.y - pose.y, req.x - pose.x)  # fixed at the start, as seed 003's turnToPoint
        self._turn(heading, req, q, {"type": "turn_to_point", "x": req.x, "y": req.y, "heading": heading})

    @query("nav/move_straight")
    def move_straight(self, req: m.MoveStraight, q: Query) -> None:
        """Drive on the start heading, steering out cross-track error; stop after `distance` if given."""
        if req.speed == 0.0:
            raise QueryError("invalid_argument", "speed: must not be 0 (use nav/stop to stop)")
        speed = math.copysign(min(abs(req.speed), self.cfg.max_speed), req.speed)
        goal = Goal(goals.MOVING_STRAIGHT, speed=speed, distance=req.distance, tolerance=self.cfg.tolerance)
        self._request(goal, req, q, {"type": "move_straight", "speed": speed, "distance": req.distance})

    @query("nav/follow_path")
    def follow_path(self, req: m.FollowPath, q: Query) -> None:
        """Drive through the points in order, each within the tolerance."""
        speed, tol = self._speed(req.speed), req.tolerance or self.cfg.tolerance
        points = tuple((float(x), float(y)) for x, y in req.points)
        goal = Goal(goals.FOLLOWING_PATH, points=points, speed=speed, tolerance=tol)
        info = {"type": "follow_path", "points": [list(p) for p in points], "speed": speed, "tolerance": tol}
        self._request(goal, req, q, info)

    @query("nav/stop")
    def stop_query(self, req: m.Empty, q: Query) -> m.StopReply:
        """Cancel the goal (and a goal waiting for its lease) and command zero at once."""
        self._drop_pending("cancelled by nav/stop before its lease was seen")
        end = self.machine.cancel("stopped")
        if end is not None:
            self._ended(end, zero=False)
        self._zero()
        self._show_changes()
        return m.StopReply(state=self.machine.state)

    @query("nav/status")
    def status_query(self, req: m.Empty, q: Query) -> m.StatusReply:
        """The state, the goal and its result, and the newest pose."""
        fb = self.machine.feedback(self.clock.now())
        return m.StatusReply(
            state=self.machine.state,
            is_moving=self.machine.active,
            goal_id=self.machine.goal_id,
            goal=self._info,
            result=self.machine.result,
            distance_remaining=fb.distance_remaining,
            pose=self._stamped(),
            not_ready=self.machine.refusal(self.clock.now()) or "",
        )

    def on_clock_reset(self) -> None:
        """The sim restarted: poses start again from t = 0, and the goal is void."""
        self._drop_pending("the stack clock restarted")
        end = self.machine.reset("the stack clock restarted")
        if end is not None:
            self._ended(end)
        self._show_changes()

    def on_stop(self) -> None:
        """Shutting down: end the goal, answer every waiter, command zero."""
        self._drop_pending("navigator shutting down")
        end = self.machine.abort("navigator shutting down")
        if end is not None:
            self._ended(end, zero=False)
        self._zero()

    # ------------------------------------------------------------ internals
    def _needed_gone(self, service: str, alive: bool) -> None:
        end = None if alive else self.machine.abort(f"{service} service gone")
        if end is not None:
            self._ended(end)
            self._show_changes()

    def _speed(self, speed: Optional[float]) -> float:
        """The forward speed of a goal, clamped to the limit."""
        return min(speed or self.cfg.speed, self.cfg.max_speed)

    def _turn(self, heading: float, req: m.TurnToHeading | m.TurnToPoint, q: Query, info: dict) -> None:
        speed = min(req.speed or self.cfg.turn_speed, self.cfg.max_turn_speed)
        tol = req.tolerance or self.cfg.heading_tolerance
        goal = Goal(goals.TURNING_TO_HEADING, heading=heading, speed=speed, tolerance=tol)
        self._request(goal, req, q, {**info, "speed": speed, "tolerance": tol})

    def _pose_or_unavailable(self) -> PoseSample:
        """The newest pose, if a goal may start on it; else an `unavailable` reply."""
        reason = self.machine.refusal(self.clock.now())
        if reason is not None:
            raise QueryError("unavailable", reason)
        return self.machine.pose

    def _request(self, goal: Goal, req: Any, q: Query, info: dict) -> None:
        """Start a goal now, or once its lease token is seen. Replies go out from here."""
        self._pose_or_unavailable()
        request = _Request(goal, info, req.wait, q)
        if req.lease is None:
            self._drop_pending("superseded by a newer goal before its lease was seen")
            self._begin(request)
            return
        if any(c in req.lease for c in "*$?#"):
            raise QueryError("invalid_argument", f"lease: {req.lease!r} must be a plain key, without wildcards")
        wid = next(self._watch_ids)
        try:
            watch = self.bus.watch_tokens(req.lease, lambda key, alive: self._lease_events.put((wid, alive)))
        except Exception as e:  # the key expression does not parse
            raise QueryError("invalid_argument", f"lease: {req.lease!r} is not a valid key: {e}") from None
        self._drop_pending("superseded by a newer goal before its lease was seen")
        request.lease, request.watch, request.watch_id = req.lease, watch, wid
        request.deadline = self.clock.now() + self.cfg.lease_grace
        self._pending = request
        self._poll_leases()  # a token already known may have been reported at once

    def _begin(self, request: _Request) -> None:
        try:
            preempted = self.machine.start(request.goal, self.clock.now())
        except Refused as e:
            self._unwatch(request)
            reply_error(request.q, "unavailable", str(e))
            return
        if preempted is not None:
            self._ended(preempted)
        gid = request.goal_id = self.machine.goal_id
        self._info, self._running = request.info, request
        speed = request.goal.speed
        self.log.info("goal %d %s %s", gid, request.goal.state, request.info)
        if request.wait:
            self._waiters[gid], self._speeds[gid] = request.q, speed
        else:
            self._reply(request.q, m.GoalReply(goal_id=gid, state=self.machine.state, speed=speed))
        self._show_changes()

    def _poll_leases(self) -> None:
        """Handle the token events the bus threads queued."""
        while True:
            try:
                wid, alive = self._lease_events.get_nowait()
            except queue.Empty:
                return
            p, r = self._pending, self._running
            if alive and p is not None and p.watch_id == wid:
                self._pending = None
                self._begin(p)
            elif not alive and r is not None and r.watch_id == wid:
                self._ended(self.machine.abort(f"lease lost: {r.lease}"))

    def _drop_pending(self, message: str) -> None:
        p, self._pending = self._pending, None
        if p is not None:
            self._unwatch(p)
            reply_error(p.q, "unavailable", message)

    def _unwatch(self, request: Optional[_Request]) -> None:
        if request is not None and request.watch is not None:
            request.watch.undeclare()
            request.watch = None

    def _ended(self, end: End, zero: bool = True) -> None:
        """A goal ended: answer its waiter, drop its lease, and command zero unless handed over."""
        log = self.log.info if end.result != goals.ABORTED else self.log.warning
        log("goal %d %s: %s", end.goal_id, end.result, end.message)
        if self._running is not None and self._running.goal_id == end.goal_id:
            self._unwatch(self._running)
            self._running = None
        if end.stop and zero:
            self._zero()
        q, speed = self._waiters.pop(end.goal_id, None), self._speeds.pop(end.goal_id, None)
        if q is not None:
            reply = m.GoalReply(
                goal_id=end.goal_id, state=self.machine.state, speed=speed, result=end.result, pose=self._stamped(), message=end.message
            )
            self._reply(q, reply)

    def _reply(self, q: Query, reply: m.GoalReply) -> None:
        try:
            reply_ok(q, reply)
        except Exception as e:  # the caller gave up (query timed out) or left
            self.warn("reply", f"could not answer goal {reply.goal_id}: {e}")

    def _zero(self) -> None:
        """Command zero velocity now (t = 0: "now", not computed from a pose)."""
        self.publish("cmd_vel", m.CmdVel(t=0.0, v=0.0, omega=0.0))

    def _stamped(self) -> Optional[m.PoseStamped]:
        p = self.machine.pose
        return None if p is None else m.PoseStamped(t=p.t, x=p.x, y=p.y, theta=p.theta)

    def _state(self, now: float) -> m.NavState:
        mc, fb = self.machine, self.machine.feedback(now)
        self._shown = (mc.state, mc.goal_id, mc.result)
        return m.NavState(
            t=now,
            state=mc.state,
            goal_id=mc.goal_id,
            goal=self._info,
            result=mc.result,
            distance_remaining=fb.distance_remaining,
            heading_error=fb.heading_error,
            eta=fb.eta,
            elapsed=fb.elapsed,
            next_point=fb.next_point,
            cross_track_error=fb.cross_track_error,
            message=mc.message,
        )

    def _show_changes(self) -> None:
        """Publish nav/state if the state, goal or result changed since it was last shown."""
        mc = self.machine
        if (mc.state, mc.goal_id, mc.result) != self._shown:
            self.publish("nav/state", self._state(self.clock.now()))

