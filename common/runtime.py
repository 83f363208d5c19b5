"""The service runtime: declared handlers, one worker, timers, diag, liveliness.

A service is a class whose methods are declared as handlers:

    class Motor(Service):
        name = "motor"

        @subscribe("cmd_vel", CmdVel)
        @publish("motors/wheels")
        def on_cmd_vel(self, msg: CmdVel) -> Wheels | None: ...

        @timer(0.05)
        def check_watchdog(self, now: float) -> None: ...

        @query("nav/stop", Empty)
        def stop(self, req: Empty, q: Query) -> StopReply: ...

Bus callbacks only enqueue; one worker runs every handler in arrival order, and
timers on the service clock in between. A payload that does not decode is counted
(`bad_input`), logged and dropped; a bad query gets an `invalid_argument` reply. A
handler that raises is logged and counted (`errors`) and the service keeps going.
A message stamped more than a second past the stack clock (clock.horizon) is
counted (`dropped_future`), logged and dropped: one bad stamp must not make every
later sample look stale.
"""
from __future__ import annotations

import logging
import queue
import threading
import time
import traceback
from dataclasses import dataclass, field
from typing import Any, Callable, Optional

from zenav.common import codec, keys
from zenav.common import messages as m
from zenav.common.bus import Bus, Query
from zenav.common.clock import Clock, SimClock, WallClock
from zenav.common.config import Settings

QUEUE_LIMIT = 10_000  # items; a full queue drops new input and counts it


class QueryError(Exception):
    """Raised by a query handler to answer with an error reply."""

    def __init__(self, code: str, message: str) -> None:
        super().__init__(message)
        self.code, self.message = code, message


def reply_error(q: Query, code: str, message: str) -> None:
    """Answer a query with the contract's error map, and end it."""
    q.reply_err(codec.encode(m.ErrorReply(error=code, message=message)))
    q.finish()


def reply_ok(q: Query, reply: m.Reply) -> None:
    """Answer a query with a reply message, and end it."""
    q.reply(codec.encode(reply))
    q.finish()


# ----------------------------------------------------------------- decorators
def subscribe(suffix: str, typ: Optional[type] = None) -> Callable:
    """Run the method for every message on `zenav/<robot>/<suffix>`, decoded as `typ`."""

    def deco(fn: Callable) -> Callable:
        fn._zenav_sub = (suffix, typ or keys.TOPICS[suffix])
        return fn

    return deco


def publish(suffix: str) -> Callable:
    """Publish the method's return value (unless None) on `suffix`."""

    def deco(fn: Callable) -> Callable:
        fn._zenav_pub = suffix
        return fn

    return deco


def timer(period: float | str) -> Callable:
    """Run the method every `period` seconds of the service clock.

    `period` is seconds, or the name of an attribute of the service holding them
    (so that config can set it: `@timer("tick_period")`).
    """

    def deco(fn: Callable) -> Callable:
        fn._zenav_timer = period
        return fn

    return deco


def query(suffix: str, typ: Optional[type] = None) -> Callable:
    """Serve queries on `suffix`; the method returns a reply, or None to reply later."""

    def deco(fn: Callable) -> Callable:
        fn._zenav_query = (suffix, typ or keys.QUERIES[suffix][0])
        return fn

    return deco


def on_liveliness(service: str) -> Callable:
    """Run the method with `alive: bool` when `service`'s liveliness token appears or goes.

    A process that dies loses its token as soon as its socket closes: faster than any
    message timeout, so safety reactions (stop the wheels) hang on it.
    """

    def deco(fn: Callable) -> Callable:
        fn._zenav_liveliness = service
        return fn

    return deco


@dataclass
class _Timer:
    period: float
    fn: Callable[[float], Any]
    due: Optional[float] = None


@dataclass
class Counters:
    """Counters and per-topic message counts, published in diag."""

    values: dict[str, int] = field(
        default_factory=lambda: {"msgs_in": 0, "msgs_out": 0, "bad_input": 0, "dropped_stale": 0, "errors": 0}
    )
    window: dict[str, int] = field(default_factory=dict)  # topic -> messages since the last diag

    def inc(self, name: str, n: int = 1) -> None:
        self.values[name] = self.values.get(name, 0) + n

    def seen(self, topic: str) -> None:
        self.window[topic] = self.window.get(topic, 0) + 1


class Service:
    """Base of every zenav service. Subclasses set `name` and declare handlers."""

    name = "service"
    config_type: Optional[type] = None  # the Struct of this service's config section
    diag_period = 1.0  # [s] of the service clock

    def __init__(self, settings: Settings, bus: Bus, clock: Clock) -> None:
        self.settings = settings
        self.cfg = settings.section(self.name, self.config_type) if self.config_type else None
        self.bus, self.clock, self.robot = bus, clock, keys.check_robot_id(settings.robot_id)
        self.log = logging.getLogger(f"zenav.{self.name}")
        self.counters = Counters()
        self.status, self.status_message = "ok", ""
        self._queue: queue.Queue = queue.Queue(QUEUE_LIMIT)
        self._timers: list[_Timer] = []
        self._handles: list = []
        self._token = None
        self._started_wall = time.monotonic()
        self._last_diag_t: Optional[float] = None  # stack-clock time of the last diag
        self._stop = threading.Event()
        self._keys: dict[str, str] = {}  # suffix -> full key (publishing is a hot path)
        self._warned: dict[str, list[float]] = {}  # warning kind -> [count, last wall time]

    # ------------------------------------------------------------ helpers
    def key(self, suffix: str) -> str:
        """Full key of a contract suffix for this robot."""
        full = self._keys.get(suffix)
        if full is None:
            full = self._keys[suffix] = keys.key(self.robot, suffix)
        return full

    def publish(self, suffix: str, msg: Any) -> None:
        """Publish a message on `zenav/<robot>/<suffix>`."""
        self.bus.publish(self.key(suffix), codec.encode(msg))
        self.counters.inc("msgs_out")
        self.counters.seen(suffix)

    def count(self, name: str, n: int = 1) -> None:
        """Increase a diag counter."""
        self.counters.inc(name, n)

    def set_status(self, status: str, message: str = "") -> None:
        """Set the diag status (ok, degraded, error) and its reason; logs changes."""
        if (status, message) != (self.status, self.status_message):
            level = logging.INFO if status == "ok" else logging.WARNING
            self.log.log(level, "status %s%s", status, f": {message}" if message else "")
        self.status, self.status_message = status, message

    def warn(self, kind: str, text: str) -> None:
        """Log a warning, at most a few lines a second per kind (the counters keep the rest)."""
        now = time.monotonic()
        seen = self._warned.setdefault(kind, [0, 0.0])
        seen[0] += 1
        if seen[0] <= 5 or now - seen[1] >= 5.0:
            suffix = f" ({seen[0]} so far)" if seen[0] > 5 else ""
            self.log.warning("%s%s", text, suffix)
            seen[1] = now

    # ------------------------------------------------------------ lifecycle
    def start(self) -> None:
        """Declare subscriptions, queryables and timers, then the liveliness token."""
        if isinstance(self.clock, SimClock):
            self._handles.append(self.bus.subscribe(self.key("clock"), self._enqueue_clock))
        for attr in dir(type(self)):
            fn = getattr(type(self), attr, None)
            if not callable(fn):
                continue
            bound = getattr(self, attr)
            if hasattr(fn, "_zenav_sub"):
                self.subscribe(*fn._zenav_sub, bound)
            if hasattr(fn, "_zenav_query"):
                suffix, typ = fn._zenav_query
                self._handles.append(self.bus.queryable(self.key(suffix), self._query_enqueuer(bound, typ)))
            if hasattr(fn, "_zenav_liveliness"):
                token_key = keys.alive(self.robot, fn._zenav_liveliness)
                self._handles.append(self.bus.watch_tokens(token_key, self._token_enqueuer(bound)))
            if hasattr(fn, "_zenav_timer"):
                period = fn._zenav_timer
                period = float(getattr(self, period) if isinstance(period, str) else period)
                self._timers.append(_Timer(period, bound))
        self._timers.append(_Timer(self.diag_period, self._publish_diag))
        self.on_start()
        self._token = self.bus.token(keys.alive(self.robot, self.name))
        self.log.info("%s up (robot %s)", self.name, self.robot)

    @classmethod
    def make_clock(cls, settings: Settings) -> Clock:
        """The clock this service runs on in its own process."""
        return SimClock() if settings.deployment.clock == "sim" else WallClock()

    def subscribe(self, suffix: str, typ: type, fn: Callable[[Any], Any]) -> None:
        """Subscribe `fn` to a topic at start-up, for subscriptions that depend on config
        (the @subscribe decorator covers the rest). `fn` may carry @publish."""
        self._handles.append(self.bus.subscribe(self.key(suffix), self._enqueuer(fn, suffix, typ)))

    def on_start(self) -> None:
        """Hook: runs once before the liveliness token is declared."""

    def on_clock_reset(self) -> None:
        """Hook: the stack clock started again (sim restarted); drop time-indexed state."""

    def on_stop(self) -> None:
        """Hook: runs once on shutdown, before the bus closes (e.g. command zero)."""

    def stop(self) -> None:
        """Ask the worker loop to end (safe from any thread or a signal handler)."""
        self._stop.set()
        try:
            self._queue.put_nowait(None)
        except queue.Full:
            pass

    def close(self) -> None:
        """Run on_stop, withdraw the token and every declaration."""
        try:
            self.on_stop()
        except Exception:
            self.log.exception("on_stop failed")
        if self._token is not None:
            self._token.undeclare()
            self._token = None
        for h in self._handles:
            try:
                h.undeclare()
            except Exception:  # the session may already be closed
                pass
        self._handles.clear()

    def run(self) -> None:
        """Process input and timers until stop()."""
        while not self._stop.is_set():
            delay = self._run_timers()
            try:
                item = self._queue.get(timeout=0.1 if delay is None else min(delay, 0.1))
            except queue.Empty:
                continue
            if item is not None:
                self._dispatch(item)

    def drain(self, limit: int = 100_000) -> int:
        """Process everything queued and every due timer, without blocking (tests)."""
        n = 0
        while n < limit:
            self._run_timers()
            try:
                item = self._queue.get_nowait()
            except queue.Empty:
                break
            if item is not None:
                self._dispatch(item)
                n += 1
        self._run_timers()
        return n

    # ------------------------------------------------------------ internals
    def _put(self, item: tuple) -> None:
        try:
            self._queue.put_nowait(item)
        except queue.Full:
            self.counters.inc("dropped_overflow")

    def _enqueue_clock(self, key: str, data: bytes) -> None:
        self._put((self._on_clock, "clock", m.Clock, data))

    def _on_clock(self, msg: m.Clock) -> None:
        if self.clock.update(msg):
            self.log.warning("stack clock jumped back to %.2f s (sim restarted): state reset", msg.t)
            self.count("clock_resets")
            for tm in self._timers:
                tm.due = None
            self.on_clock_reset()

    def _enqueuer(self, fn: Callable, suffix: str, typ: type) -> Callable[[str, bytes], None]:
        def enqueue(key: str, data: bytes) -> None:
            self._put((fn, suffix, typ, data))

        return enqueue

    def _token_enqueuer(self, fn: Callable) -> Callable[[str, bool], None]:
        def enqueue(key: str, alive: bool) -> None:
            self._put((fn, "@liveliness", None, alive))

        return enqueue

    def _query_enqueuer(self, fn: Callable, typ: type) -> Callable[[Query], None]:
        def enqueue(q: Query) -> None:
            self._put((fn, None, typ, q))

        return enqueue

    def _dispatch(self, item: tuple) -> None:
        fn, suffix, typ, data = item
        if suffix is None:
            self._dispatch_query(fn, typ, data)
            return
        if suffix == "@liveliness":
            try:
                self._publish_result(fn, fn(data))
            except Exception:
                self.counters.inc("errors")
                self.warn(f"live:{fn.__name__}", f"liveliness handler {fn.__name__} failed:\n{traceback.format_exc()}")
            return
        if suffix != "clock":
            self.counters.inc("msgs_in")
            self.counters.seen(suffix)
        try:
            msg = codec.decode(data, typ)
        except codec.BadInput as e:
            self.counters.inc("bad_input")
            self.warn(f"bad:{suffix}", f"dropped bad input on {suffix}: {e}")
            return
        t = getattr(msg, "t", None)
        if t is not None and t > self.clock.horizon():
            self.counters.inc("dropped_future")
            self.warn(f"future:{suffix}", f"dropped {suffix} stamped t={t:.3f}, {t - self.clock.now():.1f} s ahead of the clock")
            return
        try:
            out = fn(msg)
        except Exception:
            self.counters.inc("errors")
            self.warn(f"err:{suffix}", f"handler for {suffix} failed:\n{traceback.format_exc()}")
            return
        self._publish_result(fn, out)

    def _publish_result(self, fn: Callable, out: Any) -> None:
        target = getattr(fn, "_zenav_pub", None)
        if target is not None and out is not None:
            self.publish(target, out)

    def _dispatch_query(self, fn: Callable, typ: type, q: Query) -> None:
        self.counters.inc("queries")
        try:
            req = codec.decode(q.payload, typ) if q.payload else codec.from_params(q.params, typ)
        except codec.BadInput as e:
            self.counters.inc("bad_input")
            self.warn(f"badq:{q.key}", f"bad query on {q.key}: {e}")
            reply_error(q, "invalid_argument", str(e))
            return
        try:
            rep = fn(req, q)
        except QueryError as e:
            if e.code == "invalid_argument":
                self.counters.inc("bad_input")
            reply_error(q, e.code, e.message)
            return
        except Exception as e:
            self.counters.inc("errors")
            self.log.error("query %s failed:\n%s", q.key, traceback.format_exc())
            reply_error(q, "internal", f"{type(e).__name__}: {e}")
            return
        if rep is not None:
            reply_ok(q, rep)

    def _run_timers(self) -> Optional[float]:
        """Run due timers; return wall seconds until the next one (None: unknown)."""
        if not self.clock.ready:
            return None
        now = self.clock.now()
        nearest = None
        for tm in self._timers:
            if tm.due is None:
                tm.due = now + tm.period
            if now >= tm.due:
                try:
                    self._publish_result(tm.fn, tm.fn(now))
                except Exception:
                    self.counters.inc("errors")
                    self.warn(f"timer:{tm.fn.__name__}", f"timer {tm.fn.__name__} failed:\n{traceback.format_exc()}")
                tm.due += tm.period
                if tm.due <= now:  # fell behind: skip the missed runs rather than burst
                    self.counters.inc("timer_overruns")
                    tm.due = now + tm.period
            left = tm.due - now
            nearest = left if nearest is None else min(nearest, left)
        return None if nearest is None else self.clock.wall_delay(nearest)

    def diag(self, now: float) -> m.Diag:
        """The diag message now (rates per second of stack-clock time since the last one)."""
        span = max(now - self._last_diag_t, 1e-3) if self._last_diag_t is not None else self.diag_period
        self._last_diag_t = now
        rates = {k: round(v / span, 2) for k, v in self.counters.window.items()}
        self.counters.window = {}
        return m.Diag(
            t=now,
            service=self.name,
            uptime=time.monotonic() - self._started_wall,
            counters=dict(self.counters.values),
            rates=rates,
            status=self.status,
            message=self.status_message,
            queue=self._queue.qsize(),
        )

    def _publish_diag(self, now: float) -> None:
        self.publish(f"diag/{self.name}", self.diag(now))
