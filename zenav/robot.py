"""The robot library: drive a zenav robot from a Python program over the wire contract.

    from zenav import Robot

    with Robot("r1") as bot:                  # the router: connect=..., or $ZENOH_CONNECT
        bot.wait_ready(timeout=30)
        result = bot.move_to_point(1.0, 0.0, speed=0.3).wait(timeout=20)
        print(result.result, result.pose)

A goal is sent without `wait` and followed on `nav/state`: its handle (`Goal`) knows
its progress and its end, also when nobody was waiting on it, and how far the robot
has travelled since it started (summed over the poses, as LemLib's and EZ-Template's
"wait until" count it: `goal.wait_until(0.3)` returns once 30 cm are behind it). A
newer goal preempts it (result `cancelled`); a navigator that goes away aborts it. The
robot holds a liveliness token and names it as every goal's lease, so when the program
ends, dies, freezes or loses the router, the navigator stops the robot (`lease=False`
opts out: such goals run on until they end). Its session announces a LEASE_TIMEOUT
transport lease, so the router withdraws the token of a frozen program (SIGSTOP, a
hung laptop, a dropped Wi-Fi link) within that time.
Error replies raise `ZenavError`s named by the contract's error code.
"""

from __future__ import annotations

import contextlib
import functools
import math
import os
import threading
import time
import uuid
import weakref
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from typing import Any, cast

import zenoh

from zenav.common import keys
from zenav.common import messages as m
from zenav.common.bus import Handle, ZenohBus, undeclare_all
from zenav.common.client import Client, Internal, InvalidArgument, Latest, QueryBus, Unavailable, ZenavError
from zenav.common.contract import RETRYABLE, GoalResult, State
from zenav.common.geometry import wrap_angle
from zenav.common.goalschema import GoalSpec, request
from zenav.common.keys import DEFAULT_CONNECT
from zenav.common.navgoals import GoalEnd, GoalTracker
from zenav.common.roles import DRIVE_SERVICES
from zenav.goalapi import GoalMethods

__all__ = ["Goal", "Internal", "InvalidArgument", "Result", "Robot", "Unavailable", "ZenavError"]

CONNECT_TIMEOUT = 5.0  # [s] how long to look for the router
QUERY_TIMEOUT = 5.0  # [s] for a reply to a query (a goal is answered when it starts)
POSE_TIMEOUT = 5.0  # [s] pose() waits this long for a first pose
RETRIES = 2  # a goal refused on a stale pose, or before its lease was seen, is sent again at least this often
ASK_EVERY = 0.05  # [s] of stack clock: wait_ready asks the navigator again on a pose at least this much newer
LEASE_TIMEOUT = 0.3  # [s] transport lease of the robot's own session: a frozen program's goal stops this soon
DRIVE_PERIOD = 0.05  # [s] drive() sends its command this often (20 Hz, well inside the motor's command watchdog)


@dataclass(frozen=True)
class Result:
    """How a goal ended."""

    goal_id: int
    result: str  # succeeded, cancelled (stopped or preempted), aborted
    message: str  # why, in the navigator's words ("arrived", "preempted by goal 4", "pose stale: ...")
    pose: m.Pose | None  # the newest pose when the end was seen
    elapsed: float  # [s] from the goal's start to its end
    exit: str | None = None  # why the move ended: within_tolerance, passed, settled, timeout, stalled, cancelled... (None: unknown)

    @property
    def succeeded(self) -> bool:
        """Whether the goal reached its target."""
        return self.result == GoalResult.SUCCEEDED

    def __str__(self) -> str:
        p = self.pose
        where = "" if p is None else f" at x {p.x:+.3f} y {p.y:+.3f} th {math.degrees(p.theta):+.1f} deg"
        return f"goal {self.goal_id} {self.result}{': ' + self.message if self.message else ''}{where} after {self.elapsed:.1f} s"


class Goal:
    """A goal the navigator took: its progress, its end, and a way to cancel it."""

    def __init__(self, robot: Robot, reply: m.GoalReply) -> None:
        self.id = reply.goal_id
        self.reply = reply  # the navigator's answer when the goal started (state, speed used)
        self._robot = robot
        self._state: m.NavState | None = None  # newest nav/state of this goal
        self._seq = 0  # nav/state messages of this goal seen
        self._result: Result | None = None
        self._sent = time.monotonic()
        self._turn = reply.state == State.TURNING_TO_HEADING  # travelled in radians turned, not metres
        self._travelled = 0.0  # [m] or [rad] since the goal started, summed over the poses seen
        self._last: m.Pose | None = None  # the pose the sum has reached
        self._marks: list[float] = []  # travelled distances someone waits for: reaching one wakes them

    def __repr__(self) -> str:
        return f"Goal({self.id}, {self.reply.state}, {self._result.result if self._result else 'running'})"

    def done(self) -> bool:
        """Whether the goal has ended."""
        return self._result is not None

    def result(self) -> Result | None:
        """How the goal ended; None while it runs."""
        return self._result

    def feedback(self) -> m.NavState | None:
        """The newest nav/state of this goal (distance_remaining, eta, elapsed, next_point...); None before the first."""
        return self._state

    @property
    def travelled(self) -> float:
        """How far the robot has travelled since the goal started [m] (a turn: how far it turned [rad]),
        summed over the poses this program sees; it stops counting when the goal ends."""
        return self._travelled

    def wait_until(self, distance: float, timeout: float | None = None) -> bool:
        """Block until the robot has travelled `distance` [m] (a turn: turned [rad]) in this goal: True; or until the goal
        ended short of it: False (LemLib's waitUntil). TimeoutError if neither happened in `timeout` seconds."""
        with self._marked(distance), self._robot._cond:
            self._robot._cond.wait_for(functools.partial(self._reached, distance), timeout)
            if self._travelled >= distance:
                return True
        if self.done():
            return False
        self._robot._reconcile(self)
        if self.done():
            return self._travelled >= distance
        raise TimeoutError(f"goal {self.id} travelled {self._travelled:.3f} of {distance:.3f} in {timeout} s")

    def cancel(self) -> bool:
        """Stop the robot if this goal is still the running one; whether it was."""
        return self._robot._cancel(self)

    def wait(self, timeout: float | None = None) -> Result:
        """Block until the goal ends; its Result. TimeoutError if it did not end in `timeout` seconds."""
        with self._robot._cond:
            self._robot._cond.wait_for(self.done, timeout)
        if self._result is None:
            self._robot._reconcile(self)
        if self._result is None:
            raise TimeoutError(f"goal {self.id} did not end in {timeout} s")
        return self._result

    def updates(self, timeout: float | None = None) -> Iterator[m.NavState]:
        """Each new nav/state of this goal (the newest, if several came since the last), until it ends.

        TimeoutError if the goal has not ended `timeout` seconds after the first call.
        """
        cond, seq = self._robot._cond, 0
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            with cond:
                left = None if deadline is None else max(deadline - time.monotonic(), 0.0)
                news = cond.wait_for(functools.partial(self._news, seq), left)
            if not news:
                self._robot._reconcile(self)
                if not self.done():
                    raise TimeoutError(f"goal {self.id} did not end in {timeout} s")
            with cond:
                fresh, st, seq, ended = self._seq > seq, self._state, self._seq, self.done()
            if fresh and st is not None:
                yield st
            if ended:
                return

    def _news(self, seq: int) -> bool:
        """Whether a nav/state came after the `seq`-th, or the goal ended."""
        return self._seq > seq or self.done()

    def _reached(self, distance: float) -> bool:
        return self._travelled >= distance or self.done()

    @contextlib.contextmanager
    def _marked(self, distance: float) -> Iterator[None]:
        """While inside, reaching `distance` wakes the waiters."""
        with self._robot._cond:
            self._marks.append(distance)
        try:
            yield
        finally:
            with self._robot._cond:
                self._marks.remove(distance)

    def _step(self, pose: m.Pose) -> bool:
        """Add the way from the last pose to `pose` (lock held); whether a mark someone waits for was reached."""
        last, self._last = self._last, pose
        if last is None or pose.t <= last.t:  # the first, or a restarted clock: start from here
            return False
        before = self._travelled
        self._travelled += abs(wrap_angle(pose.theta - last.theta)) if self._turn else math.hypot(pose.x - last.x, pose.y - last.y)
        return any(before < mark <= self._travelled for mark in self._marks)


class Robot(GoalMethods[Goal]):
    """One robot's navigation and localization, through a Zenoh router."""

    def __init__(
        self,
        robot: str | None = None,
        connect: str | None = None,
        *,
        mode: str | None = None,
        lease: bool = True,
        connect_timeout: float = CONNECT_TIMEOUT,
        timeout: float = QUERY_TIMEOUT,
        bus: QueryBus | None = None,
    ) -> None:
        """Connect to the robot `robot` ($ZENAV_ROBOT, else r1) through the router at `connect`
        ($ZENOH_CONNECT, else tcp/127.0.0.1:7447) as a Zenoh `mode` ($ZENOH_MODE, else client;
        $ZENOH_CONFIG names a full Zenoh config). Unavailable if no router answers within
        `connect_timeout` seconds. `timeout`: seconds to wait for each query's reply.
        `bus`: talk through this bus instead (a session shared with other code, or a test's); close() leaves it open,
        and the lease token is held on it (with that session's transport lease).
        """
        robot = robot or os.environ.get("ZENAV_ROBOT") or "r1"
        try:
            keys.check_robot_id(robot)
        except ValueError as e:
            raise InvalidArgument(f"robot: {e}") from None
        own = None
        if bus is None:
            connect = connect or os.environ.get("ZENOH_CONNECT")
            mode = mode or os.environ.get("ZENOH_MODE") or "client"
            try:
                bus = own = ZenohBus.open(connect, mode, connect_timeout=connect_timeout, lease=LEASE_TIMEOUT if lease else None)
            except zenoh.ZError as e:
                raise Unavailable(f"no Zenoh router at {connect or DEFAULT_CONNECT}: {e}") from None
        self.client = Client(robot, bus=bus)
        self.robot, self.timeout = robot, timeout
        self._cond = threading.Condition()
        self._track = GoalTracker()  # what nav/state showed of each goal
        self._open: dict[int, Goal] = {}  # goals sent and not ended
        self._listeners: list[Callable[[], None]] = []
        self._handles: list[Handle] = []  # the navigator watch, the lease token
        self.lease_key = keys.key(robot, f"lease/{os.getpid()}-{uuid.uuid4().hex[:8]}") if lease else None
        try:
            self._poses = Latest()
            self.client.subscribe("pose", self._on_pose)
            self.client.subscribe("nav/state", self._on_state)
            self._handles.append(self.client.bus.watch_tokens(keys.alive(robot, "navigator"), self._on_navigator))
            if self.lease_key is not None:
                self._handles.append(self.client.bus.token(self.lease_key))
        except BaseException:
            _shut(self.client, self._handles, own)
            raise
        # Closed at interpreter exit too: an open Zenoh session can hang it.
        self._finalizer = weakref.finalize(self, _shut, self.client, self._handles, own)

    # ------------------------------------------------------------ lifecycle
    def __enter__(self) -> Robot:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Withdraw the lease (the navigator stops a goal of this robot's) and close the session (not a `bus` given)."""
        self._finalizer()

    def wait_ready(self, timeout: float = 30.0, services: Iterable[str] = DRIVE_SERVICES) -> None:
        """Block until the navigator would take a goal: `services` alive, then nav/status.not_ready
        empty (a fresh and certain pose), asked again on each newer pose. TimeoutError says why not."""
        deadline = time.monotonic() + timeout
        self.client.wait_alive(services, timeout)
        while True:
            seen = self._poses.msg
            try:
                why = self.client.query("nav/status", timeout=max(deadline - time.monotonic(), 0.1)).not_ready
            except Unavailable as e:
                why = e.message
            if not why:
                return
            try:
                self._next_pose(seen, max(deadline - time.monotonic(), 0.0), ASK_EVERY)
            except TimeoutError:
                raise TimeoutError(f"navigator not ready after {timeout:g} s: {why}") from None

    # ------------------------------------------------------------ goals (their methods: zenav.goalapi)
    def _send(self, spec: GoalSpec, fields: dict[str, Any]) -> Goal:
        return self._goal(spec.key, request(spec, fields))

    def drive(self, v: float, omega: float = 0.0, seconds: float = 0.0) -> None:
        """Drive open loop at v [m/s] and omega [rad/s] for `seconds` of this program's (wall) time, then command zero:
        what a team does to square up against a wall (back into it for a second) or to push a game piece.

        It goes to `cmd_vel`, as teleop's commands do: the motor's limits apply, and its watchdog stops the
        wheels if this program dies meanwhile. A goal that runs is stopped first (the program has the wheels,
        not the goal). Blocks until done; an exception meanwhile (Ctrl-C) still commands zero."""
        cmd = self._drive_command(v, omega, seconds)
        end = time.monotonic() + seconds
        try:
            while True:
                self.client.publish("cmd_vel", cmd)
                left = end - time.monotonic()
                if left <= 0.0:
                    return
                time.sleep(min(DRIVE_PERIOD, left))
        finally:
            self.client.publish("cmd_vel", m.CmdVel(t=0.0, v=0.0, omega=0.0))

    def stop(self) -> str:
        """Cancel whatever goal runs and command zero at once; the navigator's state."""
        return str(self.client.query("nav/stop", timeout=self.timeout).state)

    def is_moving(self) -> bool:
        """Whether a goal runs (one this robot sent that has not ended, or any the navigator shows)."""
        with self._cond:
            if self._open:
                return True
            newest = self._track.newest
        if newest is not None:
            return newest.state != State.STOPPED
        return bool(self.status().is_moving)

    # ------------------------------------------------------------ pose and status
    def pose(self, timeout: float = POSE_TIMEOUT) -> m.Pose:
        """The newest pose (map frame: x, y [m], theta [rad], t, cov...); Unavailable if none comes in `timeout` s."""
        try:
            return cast(m.Pose, self._poses.wait(timeout=timeout))
        except TimeoutError:
            raise Unavailable(f"no pose in {timeout} s: is the localizer running?") from None

    def set_pose(self, x: float | None = None, y: float | None = None, theta: float | None = None) -> m.PoseStamped:
        """Tell the localizer where the robot is (any subset of x, y [m], theta [rad], but at least one: else
        InvalidArgument, nothing sent); the pose it took."""
        request = {k: v for k, v in {"x": x, "y": y, "theta": theta}.items() if v is not None}
        if not request:
            raise InvalidArgument(m.SET_POSE_EMPTY)
        return cast(m.PoseStamped, self.client.query("localizer/set_pose", request, timeout=self.timeout))

    def status(self) -> m.StatusReply:
        """The navigator's nav/status: state, goal, result, pose, and not_ready (why a goal would be refused)."""
        return cast(m.StatusReply, self.client.query("nav/status", timeout=self.timeout))

    def on_change(self, callback: Callable[[], None]) -> None:
        """Call `callback()` whenever a goal's state may have changed (on Zenoh's thread: it must not block)."""
        self._listeners.append(callback)

    # ------------------------------------------------------------ internals
    def _drive_command(self, v: float, omega: float, seconds: float) -> m.CmdVel:
        """drive()'s command (InvalidArgument if a number is not finite, or `seconds` negative), a running goal stopped."""
        for name, value in (("v", v), ("omega", omega), ("seconds", seconds)):
            if not math.isfinite(value):
                raise InvalidArgument(f"{name}: {value} is not finite")
        if seconds < 0.0:
            raise InvalidArgument(f"seconds: {seconds} is negative")
        try:
            if self.is_moving():
                self.stop()
        except Unavailable:
            pass  # no navigator: no goal drives but this
        return m.CmdVel(t=0.0, v=float(v), omega=float(omega))

    def _goal(self, suffix: str, fields: dict[str, Any]) -> Goal:
        request = {k: v for k, v in fields.items() if v is not None}
        if self.lease_key is not None:
            request["lease"] = self.lease_key
        goal = Goal(self, self._ask(suffix, request))
        with self._cond:
            self._settle(goal)
            if not goal.done():
                goal._last = self._poses.msg  # travelled counts from here
                self._open[goal.id] = goal
        return goal

    def _ask(self, suffix: str, request: dict[str, Any]) -> m.GoalReply:
        """Send a goal; on a stale pose (a host that stalled, a link that just went) or a lease not yet seen, again
        on each newer pose for at most the query timeout (and at least RETRIES times): then the refusal is raised."""
        deadline = time.monotonic() + self.timeout
        attempt = 0
        while True:
            seen = self._poses.msg
            try:
                return cast(m.GoalReply, self.client.query(suffix, request, timeout=self.timeout))
            except Unavailable as e:
                left = deadline - time.monotonic()
                if e.reason not in RETRYABLE or (attempt >= RETRIES and left <= 0.0):
                    raise
                try:
                    self._next_pose(seen, max(left, self.timeout if attempt < RETRIES else 0.0))
                except TimeoutError:
                    raise e from None
            attempt += 1

    def _next_pose(self, seen: m.Pose | None, timeout: float, step: float = 0.0) -> None:
        """Block until a pose more than `step` seconds newer than `seen` (or from a restarted clock) arrives."""
        self._poses.wait(lambda p: seen is None or p.t > seen.t + step or p.t < seen.t, timeout)

    def _on_pose(self, pose: m.Pose) -> None:
        """A pose (on Zenoh's thread): the newest, and the open goals' travelled distance."""
        self._poses.put(pose)
        if not self._open:
            return
        with self._cond:
            marked = any([goal._step(pose) for goal in list(self._open.values())])  # every goal steps, then any
            if marked:
                self._cond.notify_all()
        if marked:
            self._changed()

    def _on_state(self, st: m.NavState) -> None:
        """A nav/state (on Zenoh's thread): update and end the goals it concerns."""
        with self._cond:
            self._track.on_state(st)
            for goal in list(self._open.values()):
                self._settle(goal)
            self._cond.notify_all()
        self._changed()

    def _on_navigator(self, key: str, alive: bool) -> None:
        """The navigator's token came or went (on Zenoh's thread): a gone navigator ends every goal."""
        if alive:
            return
        with self._cond:
            for goal in list(self._open.values()):
                self._finish(goal, GoalEnd(GoalResult.ABORTED, "navigator gone", None))
            self._track.forget()
            self._cond.notify_all()
        self._changed()

    def _changed(self) -> None:
        for callback in list(self._listeners):
            try:
                callback()
            except Exception:  # a listener must not break the subscription
                pass

    def _settle(self, goal: Goal) -> None:
        """Bring a goal up to date with what nav/state showed (lock held)."""
        st = self._track.state(goal.id)
        if st is not None and st is not goal._state:
            goal._state, goal._seq = st, goal._seq + 1
        end = self._track.end(goal.id)
        if end is not None:
            self._finish(goal, end)

    def _finish(self, goal: Goal, end: GoalEnd) -> None:
        """Give a goal its Result, once (lock held)."""
        if goal.done():
            return
        elapsed = time.monotonic() - goal._sent if end.elapsed is None else end.elapsed
        goal._result = Result(goal.id, end.result, end.message, self._poses.msg, elapsed, end.exit)
        self._open.pop(goal.id, None)

    def _reconcile(self, goal: Goal) -> None:
        """A goal not seen to end: ask nav/status whether it did while unobserved."""
        try:
            st = self.status()
        except ZenavError:
            return
        with self._cond:
            if st.goal_id == goal.id and st.result is not None:
                self._finish(goal, GoalEnd(st.result, "", None, st.exit))
            elif st.goal_id > goal.id:
                self._finish(goal, GoalEnd(GoalResult.CANCELLED, f"ended unseen; the navigator has run goal {st.goal_id} since", None))
            self._cond.notify_all()
        self._changed()

    def _cancel(self, goal: Goal) -> bool:
        with self._cond:
            running = not goal.done() and self._track.current(goal.id)
        if running:
            self.stop()
        return running


def _shut(client: Client, handles: list[Handle], own: ZenohBus | None) -> None:
    """Withdraw the lease (the navigator stops at once) and the watch, close the client, then the session it opened."""
    undeclare_all(handles)
    client.close()
    if own is not None:
        own.close()
