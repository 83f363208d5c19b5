"""The service runtime: declared handlers, one worker, timers, diag, liveliness.

A service is a class whose methods are declared as handlers:

    class Motor(Service):
        name = "motor"

        @subscribe("cmd_vel", CmdVel)
        @publish("motors/wheels")
        def on_cmd_vel(self, msg: CmdVel) -> Wheels | None: ...

        @timer(0.05)
        def check_watchdog(self, now: float) -> None: ...

        @query("nav/stop", Empty, priority=True)
        def stop(self, req: Empty, q: Query) -> StopReply: ...

One handler runs at a time, in arrival order, with timers on the service clock in
between, and the calls a handler asked for at a time of that clock (`call_at`: work due
at a time known in advance, a fix's delivery, without a timer polling for it). A
sample that finds the service idle and nothing queued is served at once on the bus's
thread that brought it (`inline`, what the deployments set: no thread
switch; never for a `blocking` service); anything else is queued for the service's
worker (services composed in one process share one worker, `Executor`, and a blocking
one has its own), and queries always are.

Its parts, each a module of zenav.common: `handlers` (the decorators), `intake` (the bus callbacks: sizes,
the queue, the priority lane, `latest`), `pacing` (input held `after` a periodic topic), `dispatch` (serving
one input: decoding, stamps, handlers, replies), `timers` (timers and `call_at`), `diagnostics` (diag),
`instances` (one instance per service and robot), `replies` (reply formats and errors) and `executor` (the
worker several services of one process share).
"""

from __future__ import annotations

import functools
import itertools
import logging
import threading
import time
from collections.abc import Callable
from typing import Any

from zenav.common import codec, keys
from zenav.common import messages as m
from zenav.common.bus import Bus, Handle, undeclare_all
from zenav.common.client import Sampled
from zenav.common.clock import FOREIGN, REFUSED, RESTARTED, Clock, SimClock, WallClock
from zenav.common.config import Settings
from zenav.common.diagnostics import WARN_LINES, Counters, CpuMeter, WarnLimit, shape
from zenav.common.dispatch import Dispatch
from zenav.common.executor import Executor, background_thread
from zenav.common.handlers import on_liveliness, publish, query, subscribe, timer
from zenav.common.inbox import Inbox
from zenav.common.instances import Duplicate, instance_id, running_for
from zenav.common.intake import Input, Intake
from zenav.common.pacing import HOLD, HOLD_WALL, Pacer
from zenav.common.replies import FORMAT_PARAM, LOG_CHARS, QueryError, clip, format_refusal, reply_error, reply_ok
from zenav.common.timers import Timers

__all__ = [  # the names services, tools and tests import from here
    "FORMAT_PARAM",
    "HOLD",
    "HOLD_WALL",
    "LOG_CHARS",
    "Duplicate",
    "Executor",
    "QueryError",
    "Service",
    "background_thread",
    "clip",
    "format_refusal",
    "on_liveliness",
    "publish",
    "query",
    "reply_error",
    "reply_ok",
    "subscribe",
    "timer",
]


class Service(Intake, Dispatch):
    """Base of every zenav service. Subclasses set `name` and declare handlers."""

    name = "service"
    config_type: type | None = None  # the Struct of this service's config section
    diag_period = 1.0  # [s] of the service clock
    # A handler may wait on I/O or compute for milliseconds (a serial link, a camera frame):
    # such a service (the class's, or an instance's by its config) is never served on a
    # bus's thread (`inline`), and composed with others it gets a worker of its own, so
    # that it holds up neither the bus nor their chain.
    blocking = False
    # Work off the control loop's path that may take long (a camera's frames): the worker that serves it runs at
    # a lower priority (`background_thread`), so that on a computer that also runs the control loop, the loop
    # gets the cores first. (The driver blocks but is on the loop's path: it is not background.)
    background = False

    def __init__(self, settings: Settings, bus: Bus, clock: Clock) -> None:
        self.settings = settings
        self.cfg: Any = settings.section(self.name, self.config_type) if self.config_type else None
        self.bus, self.clock, self.robot = bus, clock, keys.check_robot_id(settings.robot_id)
        self.log = logging.getLogger(f"zenav.{self.name}")
        self.counters = Counters()
        self.status, self.status_message = "ok", ""
        self.limits = settings.limits
        self._inbox = Inbox(self.limits.queue_items, self.limits.queue_bytes)
        self._timers = Timers()  # @timer methods, diag, and call_at
        self._overrun = functools.partial(self.counters.inc, "timer_overruns")  # made once: timers run every turn
        self._handles: list[Handle] = []
        self._token: Handle | None = None
        self._started_wall = time.monotonic()
        self._cpu = CpuMeter(self._started_wall)
        self._last_diag_t: float | None = None  # stack-clock time of the last diag
        self._stop = threading.Event()
        self._keys: dict[str, str] = {}  # suffix -> full key (publishing is a hot path)
        self._warned = WarnLimit()
        self.instance = instance_id()  # this process's (and object's) id in instance/<service>/<id>
        self._others: set[str] = set()  # instance ids of other instances of this service seen alive
        self._started = False
        self._busy = threading.Lock()  # held while this service's code runs (worker, or a bus thread serving inline)
        self.inline = False  # serve a sample on the bus's thread when nothing is queued (set by the deployments; never if blocking)
        self._pacer = Pacer(clock)  # input held for a periodic topic (@subscribe after=)
        self._arrived: float | None = None  # stack time a held input being served arrived
        self._arrivals = itertools.count(1)  # numbers the queries in the order they reach this service (bus callback)
        self._query_arrival = 0  # the number of the query being served (0: none)
        self._other_clock: set[str] = set()  # suffixes stamped on another stack's clock: not held to this one's horizon

    # ------------------------------------------------------------ helpers
    def key(self, suffix: str) -> str:
        """Full key of a contract suffix: under this robot, or a field topic's under zenav/field/."""
        full = self._keys.get(suffix)
        if full is None:
            full = self._keys[suffix] = keys.field_key(suffix) if suffix in keys.FIELD_TOPICS else keys.key(self.robot, suffix)
        return full

    def publish(self, suffix: str, msg: Any) -> None:
        """Publish a message on the suffix's key (`zenav/<robot>/<suffix>`, or a field topic's)."""
        self.bus.publish(self.key(suffix), codec.encode(msg))
        self.counters.inc("msgs_out")
        self.counters.seen(suffix)

    def arrived(self) -> float:
        """The stack time the input being served arrived: now, or when a held one came."""
        return self.clock.now() if self._arrived is None else self._arrived

    def query_arrival(self) -> int:
        """The query being served's place in the order queries reached this service: numbered on arrival, in the bus
        callback, before any queue (a priority query overtakes queued ones, and keeps its number); 0 outside a query."""
        return self._query_arrival

    def call_at(self, t: float, fn: Callable[[float], Any]) -> None:
        """Run `fn(now)` once, as a timer, when the stack clock reaches `t` (at once if it has): work
        due at a time known in advance, without a timer waking the service to look for it. Call it
        from a handler; `fn` may carry @publish. A clock reset (the sim restarted) forgets it."""
        if self._timers.call_at(t, fn):
            self._inbox.poke()  # the worker may be waiting for a later timer

    def count(self, name: str, n: int = 1) -> None:
        """Increase a diag counter."""
        self.counters.inc(name, n)

    def set_status(self, status: str, message: str = "") -> None:
        """Set the diag status (ok, degraded, error) and its reason; logs changes (not a reason's figures changing:
        "no fix for 1.5 s", then "for 2.0 s" is one line)."""
        if (status, shape(message)) != (self.status, shape(self.status_message)):
            level = logging.INFO if status == "ok" else logging.WARNING
            self.log.log(level, "status %s%s", status, clip(f": {message}") if message else "")
        self.status, self.status_message = status, message

    def warn(self, kind: str, text: str, level: int = logging.WARNING) -> None:
        """Log a warning (lines clipped), at most a few lines a second per kind (the counters keep the rest)."""
        seen = self._warned.admit(kind)
        if seen is not None:
            suffix = f" ({seen} so far)" if seen > WARN_LINES else ""
            self.log.log(level, "%s%s", clip(text), suffix)

    # ------------------------------------------------------------ lifecycle
    def start(self) -> None:
        """Declare subscriptions, queryables and timers, then the liveliness token.

        Duplicate (nothing declared) if this service already runs for this robot."""
        self._refuse_duplicate()
        self._started = True
        mine = self.key(f"instance/{self.name}/{self.instance}")
        self._handles.append(self.bus.watch_tokens(self.key(f"instance/{self.name}/*"), self._instance_enqueuer(mine)))
        if isinstance(self.clock, SimClock):
            for name in ("clock_refused", "clock_foreign", "clock_ticks"):
                self.counters.values.setdefault(name, 0)
            sim_token = self.clock.sim_token  # the clock's owner is told by the sim instances' tokens, before any tick
            self._handles.append(self.bus.watch_tokens(self.key("instance/sim/*"), lambda k, alive: sim_token(k.rsplit("/", 1)[-1], alive)))
            self._handles.append(self.bus.subscribe(self.key("clock"), self._enqueue_clock))
        for attr in dir(type(self)):
            fn = getattr(type(self), attr, None)
            if not callable(fn):
                continue
            bound = getattr(self, attr)
            if hasattr(fn, "_zenav_sub"):
                suffix, typ, after, latest = fn._zenav_sub
                if after is not None:
                    self._pacer.pace(suffix, after)
                self.subscribe(suffix, typ, bound, latest=latest)
            if hasattr(fn, "_zenav_query"):
                suffix, typ, priority, acts = fn._zenav_query
                enqueue = self._query_enqueuer(bound, suffix, typ, priority, acts)
                self._handles.append(self.bus.queryable(self.key(suffix), enqueue, urgent=priority))
            if hasattr(fn, "_zenav_liveliness"):
                self._handles.append(self.watch(keys.alive(self.robot, fn._zenav_liveliness), bound))
            if hasattr(fn, "_zenav_timer"):
                period = fn._zenav_timer
                period = float(getattr(self, period) if isinstance(period, str) else period)
                self._timers.every(period, bound)
        self._timers.every(self.diag_period, self._publish_diag)
        self.on_start()
        self._token = self.bus.token(keys.alive(self.robot, self.name))
        self._handles.append(self.bus.token(mine))
        self.log.info("%s up (robot %s, instance %s)", self.name, self.robot, self.instance)

    @classmethod
    def make_clock(cls, settings: Settings) -> Clock:
        """The clock this service runs on in its own process."""
        lim = settings.limits
        if settings.deployment.clock == "sim":
            return SimClock(future=lim.future_stamp, jump=lim.clock_jump)
        return WallClock(future=lim.future_stamp)

    def subscribe(self, suffix: str, typ: type, fn: Callable[[Any], Any], latest: bool = False, other_clock: bool = False) -> None:
        """Subscribe `fn` to a topic at start-up, for subscriptions that depend on config
        (the @subscribe decorator covers the rest). `fn` may carry @publish; `latest` as @subscribe's.
        `other_clock`: the messages are stamped on another stack's clock (another robot's sim, on
        a field topic), so a stamp ahead of this one's is no reason to drop them."""
        if other_clock:
            self._other_clock.add(suffix)
        self._handles.append(self.bus.subscribe(self.key(suffix), self._enqueuer(fn, suffix, typ, latest)))

    def newest(self, suffix: str) -> Sampled:
        """Follow a topic without serving its samples (no handler, no wake per sample): its newest message, read when
        the service asks (`Sampled.msg`), for a fast topic read at a slower one's pace; a payload that does
        not decode (`bad_input`), or a message stamped past the clock's horizon (`dropped_future`), is counted, logged
        and left out as a served one is. Undeclared as the service stops."""
        newest = self.bus.newest(self.key(suffix))
        self._handles.append(newest)

        def bad(e: codec.BadInput) -> None:
            self.counters.inc("bad_input")
            self.warn(f"bad:{suffix}", f"dropped bad input on {suffix}: {e}")

        def admit(msg: Any) -> bool:
            t = getattr(msg, "t", None)
            if t is None or self.clock.admits(t):
                return True
            self.counters.inc("dropped_future")
            self.warn(f"future:{suffix}", f"dropped {suffix} stamped t={t:.3f}, {t - self.clock.now():.3f} s ahead of the clock")
            return False

        return Sampled(newest, keys.topic_type(suffix), bad, admit)

    def watch(self, key: str, fn: Callable[[bool], Any]) -> Handle:
        """Watch a liveliness token key at run time: `fn(alive)` runs in the worker on each
        appearance and loss (ahead of queued input). `fn` may carry @publish. Undeclare the
        handle to stop; a key that does not parse raises."""
        return self.bus.watch_tokens(key, self._token_enqueuer(fn))

    def on_start(self) -> None:
        """Hook: runs once before the liveliness token is declared."""

    def on_priority(self, suffix: str, queued: bool, arrival: int) -> None:
        """Hook: a priority query on `suffix` (its exact key) just arrived, numbered `arrival` (query_arrival), and is
        `queued` for the worker (False: the queue refused it). Runs at once on the bus's thread, beside the
        worker: keep it short and thread-safe."""

    def on_clock_reset(self) -> None:
        """Hook: the stack clock started again (sim restarted); drop time-indexed state."""

    def on_stop(self) -> None:
        """Hook: runs once on shutdown, before the bus closes (e.g. command zero)."""

    def stop(self) -> None:
        """Ask the worker loop to end (safe from any thread or a signal handler); input from now
        on is only queued, not served."""
        self.inline = False
        self._stop.set()
        self._inbox.put(None, priority=True)

    def close(self) -> None:
        """Run on_stop (if started), withdraw the token and every declaration. on_stop runs
        after any handler still running on a bus thread, and none runs after it."""
        self.inline = False
        try:
            if self._started:
                with self._busy:
                    self.on_stop()
        except Exception:
            self.log.exception("on_stop failed")
        if self._token is not None:
            self._token.undeclare()
            self._token = None
        undeclare_all(self._handles)

    def run(self) -> None:
        """Process input and timers until stop() (on this thread, lowered first if the service is `background`)."""
        if self.background:
            background_thread()
        while not self._stop.is_set():
            delay = self.turn(Executor.ROUND)
            self._inbox.wait(Executor.IDLE if delay is None else min(delay, Executor.IDLE))

    def turn(self, budget: int) -> float | None:
        """Without blocking: dispatch up to `budget` queued items, then the due timers (a
        worker's step). Wall seconds until the next timer (None: unknown)."""
        with self._busy:
            for _ in range(budget):
                got, item = self._inbox.get()
                if not got:
                    break
                if item is not None:
                    self._serve(item)
            if self._pacer.held:
                wait = self._pacer.wait()
                if wait <= 0.0:
                    self._release()
                else:
                    delay = self._run_timers()
                    return wait if delay is None else min(delay, wait)
            return self._run_timers()

    def drain(self, limit: int = 100_000) -> int:
        """Process everything queued (held input included) and every due timer, without blocking (tests)."""
        n = 0
        while n < limit:
            self._run_timers()
            got, item = self._inbox.get()
            if not got:
                break
            if item is not None:
                self._serve(item)
                n += 1
        self._release()
        self._run_timers()
        return n

    # ------------------------------------------------------------ internals

    def _serve(self, item: Input) -> None:
        """Dispatch an item, or hold it for the worker (`after`).

        A held input is served after the sample of its topic that comes next (the worker
        serves it in the gap after that one) and before anything that comes after that
        sample: in a run replayed faster or slower, it lands between the same inputs."""
        kind, suffix = item.kind, item.suffix
        pacer = self._pacer
        if pacer.held and (kind == "query" or pacer.waited() or pacer.overdue()):
            self._release()  # a query, or anything after the sample held input waited for, comes after it
        if kind != "msg":
            self._dispatch(item)
            return
        after = pacer.held_for.get(suffix)
        if after is not None:
            if pacer.hold(after, item):  # it flows
                self._inbox.poke()  # the worker waits for it
                return
            if pacer.held:
                self._release()  # in arrival order
        self._dispatch(item)
        if pacer.served(suffix):
            self._inbox.poke()  # its gap begins

    def _release(self) -> None:
        """Serve every held input, oldest first, as of its arrival."""
        for held in self._pacer.take():
            self._arrived = held.arrived
            try:
                self._dispatch(held.item)
            finally:
                self._arrived = None

    def _refuse_duplicate(self) -> None:
        """Raise Duplicate, naming the other instance, if this service's token is declared."""
        names = self.running_for(self.robot)
        if names is not None:
            raise Duplicate(f"another {self.name} already runs for robot {self.robot} ({names}); stop it first")

    def running_for(self, robot: str) -> str | None:
        """The ids of the instances of this service that run for `robot` (its tokens), comma-separated; None: none."""
        return running_for(self.bus, robot, self.name)

    def _other_instance(self, other: str, alive: bool) -> None:
        """Another instance of this service came or went (diag shows error while one runs)."""
        (self._others.add if alive else self._others.discard)(other)
        if alive:
            self.log.error("another %s runs for robot %s: instance %s (this is %s)", self.name, self.robot, other, self.instance)

    def _on_clock(self, msg: m.Clock) -> None:
        clock = self.clock
        assert isinstance(clock, SimClock)  # the clock topic is subscribed only then
        outcome = clock.update(msg)
        if outcome == REFUSED:
            self.count("clock_refused")
            self.warn("clock_refused", f"refused a clock tick t={msg.t:.3f} rtf={msg.rtf:g}: {clock.refusal}")
        elif outcome == FOREIGN:
            self.count("clock_foreign")
            self.warn("clock_foreign", f"dropped a clock tick t={msg.t:.3f}: {clock.refusal}")
        elif outcome == RESTARTED:
            self.log.warning("stack clock at %.2f s from sim instance %s (sim restarted): state reset", msg.t, msg.instance or "-")
            self.count("clock_resets")
            self._timers.reset()
            self.on_clock_reset()
            # At once, not a diag period of the new time later: a supervisor that heard nothing
            # while the sim was down (no clock, no timers) must not take the service for hung.
            self._last_diag_t = None
            self._publish_diag(self.clock.now())

    def _run_timers(self) -> float | None:
        """Run due timers and calls (call_at); return wall seconds until the next one (None: unknown)."""
        if not self.clock.ready:
            return None
        left = self._timers.run(self.clock.now(), self._fire, self._overrun)
        return None if left is None else self.clock.wall_delay(left)

    def diag(self, now: float) -> m.Diag:
        """The diag message now (rates per second of stack-clock time since the last one)."""
        span = max(now - self._last_diag_t, 1e-3) if self._last_diag_t is not None else self.diag_period
        self._last_diag_t = now
        rates = self.counters.take_rates(span)
        busy = self._cpu.busy()
        serve = self.counters.take_serve()
        status, message = self.status, self.status_message
        if self._others:
            status = "error"
            message = f"another {self.name} runs for robot {self.robot}: {', '.join(sorted(self._others))} (this is {self.instance})"
        return m.Diag(
            t=now,
            service=self.name,
            uptime=time.monotonic() - self._started_wall,
            counters=dict(self.counters.values),
            rates=rates,
            status=status,
            message=message,
            queue=self._inbox.qsize() + len(self._pacer.held),
            cpu=round(busy, 4),
            serve=serve,
        )

    def _publish_diag(self, now: float) -> None:
        self.publish(f"diag/{self.name}", self.diag(now))
