"""The navigator service: nav/* goals in, cmd_vel per pose while a goal runs, nav/state out.

Its control loop runs on each odom sample (`[navigator] control_on = "odom"`), placed in the
map frame by the localizer's newest correction (correction.py: the pose less the odom sample
of the pose's t), or on each of the localizer's poses ("pose"). On odom the localizer is off
the sensor-to-wheel path; the pose's age still counts for staleness, its cov for uncertainty.

Goal queries reply at once with the goal id, or with `wait` when the goal ends.
A `lease` names a liveliness token the caller holds: the goal starts once the token
is seen alive (the request is answered `unavailable` if it is not seen within
`lease_grace`), and is aborted, with the robot stopped, when the token disappears
(its holder closed, died, or went silent past its session's transport lease: the
robot library's LEASE_TIMEOUT). A goal without a lease runs until it ends or is stopped.
nav/stop goes ahead of every other queued input, and commands zero the moment it
arrives (`on_priority`, on the bus's thread): until the worker has handled it, the
worker sends no cmd_vel, so nothing computed before the stop follows its zero. A stop
voids every goal that reached the navigator before it (by the runtime's arrival
numbers): one running is cancelled, and one still queued, or in hand when the stop came,
is answered `unavailable` and never starts; only goals that arrive after the stop drive.
Targets outside the [field] are refused. Diag status is `error` while the motor is
gone, or while a goal is wanted and no usable pose comes. A pose too uncertain
(`max_position_sigma`, `max_heading_sigma`) refuses and aborts goals once a vps has been
seen (its liveliness token): the fixes keep the pose certain, so an uncertain one means they
stopped. A robot without a VPS drives on odometry alone, whose uncertainty grows with every
metre (as LemLib's and EZ-Template's robots do all match): its goals drive, nav/state and
nav/status report the sigmas, and the first goal that runs past a limit logs it once.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable
from typing import Any

from zenav.common import messages as m
from zenav.common.bus import Bus, Query
from zenav.common.clock import Clock
from zenav.common.config import ConfigError, Settings
from zenav.common.contract import ErrorCode, GoalResult, Reason
from zenav.common.geometry import wrap_angle
from zenav.common.others import Others
from zenav.common.runtime import QueryError, Service, on_liveliness, publish, query, reply_error, reply_ok, subscribe, timer
from zenav.services.navigator import goals, intake, planner, routing
from zenav.services.navigator.controllers import PoseSample, Wheelbase, check_polar_gains, sigmas
from zenav.services.navigator.correction import Paired, Pairing
from zenav.services.navigator.goals import End, Refused
from zenav.services.navigator.params import Params
from zenav.services.navigator.requests import LOST, START, Request, Requests
from zenav.services.navigator.traffic import Other, Traffic
from zenav.services.navigator.traffic_machine import COUNTERS, TrafficMachine

LEASE_CHARS = 256  # a lease key longer than this is refused (it shows in nav/state and the log)
FIELD_PERIOD = 1.0  # [s] between two `field` messages
BODY_KEPT = 0.5  # [s] another robot's body not heard from for this long is forgotten (as the motor's guard does)


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
        self.area = settings.field
        wheels = Wheelbase(r.track_width, r.wheel_radius, r.max_wheel_speed)
        self.planner = planner.Planner(self.area, r.radius + self.area.margin)  # the field's visibility graph, built once
        traffic = Traffic(self.robot, r.radius, self.area.margin, self.planner) if cfg.avoid_robots else None
        self.machine = TrafficMachine(cfg, wheels, self.area, gated=False, traffic=traffic)
        self.others: Others[Other] = Others(self.robot, BODY_KEPT)  # the other robots' bodies
        for name in COUNTERS:
            self.count(name, 0)
        self._doubt_told = False  # the warning that a goal drives on an uncertain pose (no vps) was logged
        self.requests = Requests()
        self.radius = r.radius  # [m] the footprint
        self._plan: list[tuple[float, ...]] | None = None  # the newest goal's points as driven
        self._guard = ""  # what the motor's guard holds the commands back for now ("": nothing)
        self._info: dict[str, Any] | None = None  # the newest goal, as nav/state shows it
        self._shown: tuple[Any, ...] | None = None  # (state, goal_id, result) last published
        self._motor_gone = False  # the motor's token went (and has not come back)
        self._pose_wanted = False  # a goal was refused or aborted for want of a usable pose
        self._cmd_lock = threading.Lock()  # cmd_vel from the worker vs the zero of an arriving stop
        self._stops = 0  # nav/stop queries arrived (queued) but not yet handled: no cmd_vel from the worker
        self._stopped_at = 0  # arrival number (Service.query_arrival) of the newest nav/stop: goals that came before are void
        self._holding: Request | None = None  # a chained goal's request, its lease watched while its last command is held
        # control on odom: the odom samples and poses paired for the localizer's correction (None: control on pose)
        self.pairing: Pairing[m.Pose] | None = Pairing() if cfg.control_on == "odom" else None

    # ------------------------------------------------------------ inputs
    @subscribe("pose", latest=True)  # a navigator behind its input acts on the newest pose
    def on_pose(self, msg: m.Pose) -> None:
        """Control on pose: run the goal on each pose. On odom: pair it with its odom sample, for the correction."""
        sample = PoseSample(msg.t, msg.x, msg.y, wrap_angle(msg.theta), msg.v, msg.omega, *sigmas(msg.cov), msg.slipping)
        if self.pairing is not None:
            paired = self.pairing.on_pose(msg.t, (msg.x, msg.y, msg.theta), msg)
            if paired == Paired.OUT_OF_ORDER:
                self._out_of_order("pose", f"t {msg.t:.3f} < {self.pairing.t or 0.0:.3f}")
            elif paired == Paired.UNPAIRED:
                self.count("poses_unpaired")
            elif paired == Paired.PAIRED:
                self.machine.heard(sample)
                self._show_changes()
                if self.status != "ok":
                    self._health(self.clock.now())
            return
        last = self.machine.pose
        if last is not None and msg.t < last.t:
            self._out_of_order("pose", f"t {msg.t:.3f} < {last.t:.3f}")
            return
        self._drive(sample)

    def on_odom(self, msg: m.Odom) -> None:
        """Control on odom: run the goal on each odom sample in the map frame, by the newest pose's correction."""
        assert self.pairing is not None
        try:
            at = self.pairing.on_odom(msg.t, (msg.x, msg.y, msg.theta))
        except ValueError as e:
            self._out_of_order("odom", str(e))
            return
        pose = self.pairing.pose
        if at is None or pose is None:
            return  # no pose paired yet: nothing to steer on
        self._drive(PoseSample(msg.t, at[0], at[1], wrap_angle(at[2]), msg.v, msg.omega, *sigmas(pose.cov), pose.slipping, pose.t))

    def _out_of_order(self, topic: str, why: str) -> None:
        self.count("dropped_stale")
        self.warn(f"{topic}_order", f"dropped a{'n' if topic == 'odom' else ''} {topic} out of order ({why})")

    def _drive(self, sample: PoseSample) -> None:
        """Run the goal on a pose: the command acts on (and carries the t of) this pose."""
        why = self.machine.why
        cmd, end = self.machine.drive(sample, self._bodies())
        for name, n in self.machine.counts.items():
            self.count(name, n)
        self.machine.counts.clear()
        if self.machine.why != why:
            if self.machine.why:
                self.log.info("goal %d: %s", self.machine.goal_id, self.machine.why)
            self.publish("nav/state", self._state(self.clock.now()))
        if end is not None:
            self._ended(end, zero=False)  # the zero goes out below, with this pose's t
        if self._holding is not None:
            self._hold_over()
        self._show_changes()
        if self.status != "ok":
            self._health(self.clock.now())
        if cmd is not None:
            with self._cmd_lock:
                if self._stops <= 0:  # -1 for a moment when the worker handles a stop before its hook ran
                    self.publish("cmd_vel", m.CmdVel(t=sample.t, v=cmd[0], omega=cmd[1], way=self.machine.way()))

    @timer("check_period")
    def check(self, now: float) -> None:
        """The lease grace, stale pose and progress checks, and the diag status."""
        p = self.requests.expired(now)
        if p is not None:
            self._refuse(p, f"lease {p.lease} is not alive", Reason.LEASE_UNSEEN)
        end = self.machine.check(now)
        if end is not None:
            self._pose_wanted = self._pose_wanted or self.machine.refusal(now) is not None
            self._ended(end)
        if self._holding is not None:
            self._hold_over()
        self._show_changes()
        self._health(now)
        if self.machine.active and not self.machine.gated and not self._doubt_told:
            doubt = self.machine.uncertain()
            if doubt is not None:
                self._doubt_told = True
                self.log.warning("driving on odometry alone: %s (no vps runs: nothing is refused for it; nav/state has the sigmas)", doubt)

    @on_liveliness("motor")
    def motor_presence(self, alive: bool) -> None:
        """The motor service went: the goal cannot go on (a restarted motor must not resume it)."""
        self._motor_gone = not alive
        self._needed_gone("motor", alive)
        self._health(self.clock.now())

    @on_liveliness("localizer")
    def localizer_presence(self, alive: bool) -> None:
        """The localizer went: abort at once rather than when its pose turns stale."""
        self._needed_gone("localizer", alive)

    @on_liveliness("vps")
    def vps_presence(self, alive: bool) -> None:
        """A vps runs: from now on an uncertain pose means the fixes stopped, and refuses and aborts goals (a vps that goes
        away later leaves the robot without its fixes: the check stays)."""
        if alive and not self.machine.gated:
            self.machine.gated = True
            self.log.info("a vps runs: goals are refused and aborted while the pose is too uncertain")

    @on_liveliness("odometry")
    def odometry_presence(self, alive: bool) -> None:
        """The odometry went: no more poses will come; abort at once."""
        self._needed_gone("odometry", alive)

    @subscribe("diag/driver")
    def driver_status(self, msg: m.Diag) -> None:
        """A real robot's motor board went (unplugged, not answering): abort at once, saying why."""
        end = self.machine.abort(f"driver: {msg.message or 'error'}") if msg.status == "error" else None
        if end is not None:
            self._ended(end)
            self._show_changes()

    def on_body(self, msg: m.Body) -> None:
        """Another robot's body on the field (this robot's own comes back too: not kept)."""
        v, theta = msg.v or 0.0, msg.theta or 0.0
        way = tuple((p[0], p[1]) for p in msg.way)  # where it is going, when it tells it
        other = Other(msg.robot, msg.x, msg.y, msg.radius, v * math.cos(theta), v * math.sin(theta), way)
        self.others.heard(msg.robot, self.clock.now(), other)

    def on_start(self) -> None:
        if self.pairing is not None:
            self.subscribe("odom", m.Odom, self.on_odom, latest=True)  # as the pose: the newest sample
        if self.cfg.avoid_robots:
            self.subscribe("robots", m.Body, self.on_body, other_clock=True)  # each robot stamps on its own clock

    @subscribe("motor/guard")
    def guard_state(self, msg: m.GuardState) -> None:
        """What the motor's safety layer holds the commands back for: shown on nav/state at once."""
        if msg.reason != self._guard:
            self._guard = msg.reason
            self.publish("nav/state", self._state(self.clock.now()))

    @timer(FIELD_PERIOD)
    @publish("field")
    def field_tick(self, now: float) -> m.FieldMap:
        """The field as this navigator knows it, for views and recordings."""
        a = self.area
        shapes = [
            {"name": s.name, "circle": list(s.circle)}
            if s.circle is not None
            else {"name": s.name, "polygon": [list(p) for p in s.polygon]}
            for s in self.planner.shapes
        ]
        return m.FieldMap(
            t=now,
            enabled=a.enabled,
            x_min=a.x_min,
            x_max=a.x_max,
            y_min=a.y_min,
            y_max=a.y_max,
            obstacles=shapes,
            radius=self.radius,
            margin=a.margin,
        )

    @timer("state_period")
    @publish("nav/state")
    def state_tick(self, now: float) -> m.NavState:
        """nav/state at 5 Hz, between changes."""
        return self._state(now)

    # ------------------------------------------------------------ queries
    @query("nav/move_to_point")
    def move_to_point(self, req: m.MoveToPoint, q: Query) -> None:
        """Drive to (x, y) with the configured point tracker."""
        self._request(intake.move_to_point, req, q)

    @query("nav/move_to_pose")
    def move_to_pose(self, req: m.MoveToPose, q: Query) -> None:
        """Drive to (x, y) and arrive with heading theta ([navigator] pose_controller)."""
        self._request(intake.move_to_pose, req, q)

    @query("nav/turn_to_heading")
    def turn_to_heading(self, req: m.TurnToHeading, q: Query) -> None:
        """Turn in place to a heading."""
        self._request(intake.turn_to_heading, req, q)

    @query("nav/turn_to_point")
    def turn_to_point(self, req: m.TurnToPoint, q: Query) -> None:
        """Turn in place to face (x, y), the heading taken from the pose at the start."""
        self._request(lambda r, cfg: intake.turn_to_point(r, cfg, self._pose_or_unavailable()), req, q)

    @query("nav/swing_to_heading")
    def swing_to_heading(self, req: m.SwingToHeading, q: Query) -> None:
        """Turn to a heading about one locked wheel."""
        self._request(intake.swing_to_heading, req, q)

    @query("nav/move_straight")
    def move_straight(self, req: m.MoveStraight, q: Query) -> None:
        """Drive on the start heading, steering out cross-track error; stop after `distance` if given."""
        self._request(intake.move_straight, req, q)

    @query("nav/follow_path")
    def follow_path(self, req: m.FollowPath, q: Query) -> None:
        """Drive through the points in order, each within the tolerance."""
        self._request(intake.follow_path, req, q)

    @query("nav/stop", priority=True)
    def stop_query(self, req: m.Empty, q: Query) -> m.StopReply:
        """Cancel the goal (and a goal waiting for its lease) and command zero, ahead of any queued input
        (on_priority commanded zero already, when the query arrived)."""
        self._drop_pending("cancelled by nav/stop before its lease was seen", Reason.STOPPED)
        end = self.machine.cancel("stopped")
        with self._cmd_lock:
            self._zero()
            self._stops -= 1
        if end is not None:
            self._ended(end, zero=False)
        self._pose_wanted = False
        self._show_changes()
        self._health(self.clock.now())
        return m.StopReply(state=self.machine.state)

    @query("nav/status", acts=False)
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
            not_ready=self._not_ready(),
            exit=self.machine.exit,
            position_sigma=self._sigmas()[0],
            heading_sigma=self._sigmas()[1],
            plan=self._plan,
        )

    def on_priority(self, suffix: str, queued: bool, arrival: int) -> None:
        """nav/stop arrived (bus thread): zero now; the worker sends no cmd_vel until it has handled the stop, and starts
        no goal that arrived before it."""
        with self._cmd_lock:
            self._zero()
            self._stops += queued
            self._stopped_at = max(self._stopped_at, arrival)

    def on_clock_reset(self) -> None:
        """The sim restarted: poses start again from t = 0, and the goal is void."""
        self._drop_pending("the stack clock restarted", Reason.RESTARTED)
        if self.pairing is not None:
            self.pairing.reset()
        end = self.machine.reset("the stack clock restarted")
        if end is not None:
            self._ended(end)
        self._show_changes()

    def on_stop(self) -> None:
        """Shutting down: end the goal, answer every waiter, command zero."""
        self._drop_pending("navigator shutting down", Reason.SHUTTING_DOWN)
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

    def _bodies(self) -> list[Other]:
        """The other robots heard within BODY_KEPT."""
        return list(self.others.at(self.clock.now()).values())

    def _pose_or_unavailable(self) -> PoseSample:
        """The newest pose, if a goal may start on it; else an `unavailable` reply."""
        now = self.clock.now()
        reason = self.machine.refusal(now)
        if reason is not None:
            self._pose_wanted = True
            self._health(now)
            raise QueryError(ErrorCode.UNAVAILABLE, reason.message, reason.reason)
        pose = self.machine.pose
        assert pose is not None  # no refusal: there is a pose
        return pose

    def _request(self, resolve: Callable[[Any, Params], intake.Resolved], req: Any, q: Query) -> None:
        """Resolve a goal request, then start it now or once its lease token is seen. Replies go out from here."""
        try:
            goal, info = resolve(req, self.cfg)
        except intake.Invalid as e:
            raise QueryError(ErrorCode.INVALID_ARGUMENT, str(e)) from None
        if self._motor_gone:
            raise QueryError(ErrorCode.UNAVAILABLE, "the motor service is gone: no goal can be driven", Reason.MOTOR_GONE)
        pose = self._pose_or_unavailable()
        out = goals.outside(goal, pose, self.area)
        if out is not None:
            raise QueryError(ErrorCode.INVALID_ARGUMENT, out)
        if self.query_arrival() < self._stopped_at:  # a stop came after it, however late (one held for its lease: stop_query)
            self.count("goals_voided")
            raise QueryError(ErrorCode.UNAVAILABLE, "cancelled by nav/stop: the stop reached the navigator after this goal", Reason.STOPPED)
        asked = len(goal.points)
        try:
            if getattr(req, "plan", False):
                goal = routing.route(goal, (pose.x, pose.y), self.radius, self.planner, self.cfg.corner_tolerance)
            else:
                routing.check_targets(goal, self.planner)
        except routing.Blocked as e:
            raise QueryError(ErrorCode.INVALID_ARGUMENT, str(e)) from None
        request = Request(goal, info, req.wait, q, detours=len(goal.points) - asked)
        if req.lease is None:
            self._drop_pending("superseded by a newer goal before its lease was seen", Reason.SUPERSEDED)
            self._begin(request)
            return
        if len(req.lease) > LEASE_CHARS:
            raise QueryError(ErrorCode.INVALID_ARGUMENT, f"lease: {len(req.lease)} characters is over {LEASE_CHARS}")
        if any(c in req.lease for c in "*$?#"):
            raise QueryError(ErrorCode.INVALID_ARGUMENT, f"lease: {req.lease!r} must be a plain key, without wildcards")
        try:
            request.watch = self.watch(req.lease, lambda alive: self._on_lease(request, alive))
        except Exception as e:  # the key expression does not parse
            raise QueryError(ErrorCode.INVALID_ARGUMENT, f"lease: {req.lease!r} is not a valid key: {e}") from None
        old = self.requests.hold(request, req.lease, self.clock.now() + self.cfg.lease_grace)
        if old is not None:
            self._refuse(old, "superseded by a newer goal before its lease was seen", Reason.SUPERSEDED)

    def _on_lease(self, request: Request, alive: bool) -> None:
        """A token event of a request's lease (in the worker, like any input)."""
        event = self.requests.on_lease(request, alive)
        if event == START:
            self._begin(request)
        elif event == LOST:
            end = self.machine.abort(f"lease lost: {request.lease}")
            if end is not None:
                self._ended(end)
            self._show_changes()
        elif not alive and request is self._holding:  # its holder went before it sent the goal to chain into
            self.machine.abort(f"lease lost: {request.lease}")  # no goal runs: this ends the held command
            self._zero()
            self.log.warning("lease lost: %s; the held command of chained goal %d ended", request.lease, request.goal_id)
            self._hold_over()

    def _begin(self, request: Request) -> None:
        try:
            preempted = self.machine.start(request.goal, self.clock.now())
        except Refused as e:
            self._pose_wanted = True
            self._refuse(request, str(e), e.reason)
            return
        if preempted is not None:
            self._ended(preempted)
        if self._holding is not None:
            self._hold_over()
        gid = self.machine.goal_id
        self.requests.started(request, gid)
        self._info = request.info
        self.log.info("goal %d %s %s", gid, request.goal.state, _brief(request.info))
        self._publish_plan(request, gid)
        if not request.wait:
            self._reply(request.reply_to, m.GoalReply(goal_id=gid, state=self.machine.state, speed=request.goal.speed))
        self._show_changes()

    def _publish_plan(self, request: Request, goal_id: int) -> None:
        """nav/plan: the points the goal drives through (none for a turn or a straight)."""
        goal = request.goal
        if not goal.points:
            self._plan = None
            return
        start = self.machine.pose
        assert start is not None  # the goal started: there is a pose
        here = (start.x, start.y)
        points = [(float(x), float(y)) for x, y in goal.points]
        self._plan = [*points]
        gap = planner.clearance(self.planner.shapes, here, points)
        msg = m.Plan(
            t=start.t,
            goal_id=goal_id,
            points=self._plan,
            length=planner.length(here, points),
            planned=request.detours > 0,
            clearance=None if gap == float("inf") else gap,
        )
        self.publish("nav/plan", msg)

    def _refuse(self, request: Request, message: str, reason: Reason) -> None:
        """Answer a request that will not start `unavailable` for `reason`, and release its lease watch."""
        self._unwatch(request)
        reply_error(request.reply_to, ErrorCode.UNAVAILABLE, message, reason=reason)

    def _drop_pending(self, message: str, reason: Reason) -> None:
        p = self.requests.take_pending()
        if p is not None:
            self._refuse(p, message, reason)

    def _not_ready(self) -> str:
        """Why a goal would be refused now ("": it would start)."""
        refusal = self.machine.refusal(self.clock.now())
        return "" if refusal is None else refusal.message

    def _unwatch(self, request: Request | None) -> None:
        if request is not None and request.watch is not None:
            request.watch.undeclare()
            request.watch = None

    def _ended(self, end: End, zero: bool = True) -> None:
        """A goal ended: answer its waiter, drop its lease, and command zero unless handed over."""
        log = self.log.info if end.result != GoalResult.ABORTED else self.log.warning
        log("goal %d %s: %s", end.goal_id, end.result, end.message)
        done, waiter = self.requests.ended(end.goal_id)
        if done is not None and done.watch is not None and not end.stop and self.machine.coasting:
            self._holding = done  # its lease still watched: the held command ends with its holder
        else:
            self._unwatch(done)
        if end.stop and zero:
            self._zero()
        if waiter is not None:
            reply = m.GoalReply(
                goal_id=end.goal_id,
                state=self.machine.state,
                speed=waiter.goal.speed,
                result=end.result,
                pose=self._stamped(),
                message=end.message,
                exit=end.exit,
            )
            self._reply(waiter.reply_to, reply)

    def _health(self, now: float) -> None:
        """Diag status: error while the motor is gone or a goal is wanted without a usable pose."""
        refusal = self.machine.refusal(now)
        if refusal is None:
            self._pose_wanted = False
        if self._motor_gone:
            self.set_status("error", "motor service gone: goals cannot be driven")
        elif self._pose_wanted:
            self.set_status("error", f"a goal is wanted but {refusal.message if refusal else ''}")
        else:
            self.set_status("ok")

    def _reply(self, q: Query, reply: m.GoalReply) -> None:
        try:
            reply_ok(q, reply)
        except Exception as e:  # the caller gave up (query timed out) or left
            self.warn("reply", f"could not answer goal {reply.goal_id}: {e}")

    def _hold_over(self) -> None:
        """Stop watching the lease of a chained goal whose held command is over (or was taken over)."""
        if not self.machine.coasting:
            self._unwatch(self._holding)
            self._holding = None

    def _zero(self) -> None:
        """Command zero velocity now (t = 0: "now", not computed from a pose)."""
        self.publish("cmd_vel", m.CmdVel(t=0.0, v=0.0, omega=0.0))

    def _sigmas(self) -> tuple[float | None, float | None]:
        """(position [m], heading [rad]) 1 sigma of the newest pose; None before the first."""
        p = self.machine.pose
        return (None, None) if p is None else (p.sigma_xy, p.sigma_theta)

    def _stamped(self) -> m.PoseStamped | None:
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
            exit=mc.exit,
            position_sigma=self._sigmas()[0],
            heading_sigma=self._sigmas()[1],
            guard=self._guard,
            traffic=self.machine.why,
        )

    def _show_changes(self) -> None:
        """Publish nav/state if the state, goal or result changed since it was last shown."""
        mc = self.machine
        if (mc.state, mc.goal_id, mc.result) != self._shown:
            self.publish("nav/state", self._state(self.clock.now()))


def _brief(info: dict[str, Any]) -> dict[str, Any]:
    """A goal map for the log: a long path shown by its length."""
    points = info.get("points")
    if points is not None and len(points) > 4:
        return {**info, "points": f"{len(points)} points, last {points[-1]}"}
    return info
