"""A client of a running stack: queries, subscriptions and liveliness (the robot library, CLI, tests, bench).

Errors are `ZenavError`s carrying the contract's error code (`invalid_argument`,
`unavailable`, `internal`), one subclass per code, and the reply's `reason` (a contract.Reason,
or ""): the class and the reason are what a program decides on, never the message's words.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterable
from typing import Any, Protocol

import msgspec
import zenoh

from zenav.common import codec, keys
from zenav.common import messages as m
from zenav.common.bus import Bus, Handle, Newest, ZenohBus, undeclare_all, zenoh_config
from zenav.common.contract import ErrorCode
from zenav.common.keys import DEFAULT_CONNECT


class ZenavError(Exception):
    """An error reply of the stack, or no reply at all; `code` is the contract's error code, `reason` its Reason ("": none)."""

    def __init__(self, code: str, message: str, reason: str = "") -> None:
        super().__init__(f"{code}: {message}")
        self.code, self.message, self.reason = code, message, reason


class InvalidArgument(ZenavError, ValueError):
    """A request the stack refuses as bad input (the message names the field)."""

    def __init__(self, message: str, reason: str = "") -> None:
        super().__init__(ErrorCode.INVALID_ARGUMENT, message, reason)


class Unavailable(ZenavError):
    """No router, no reply, or the stack cannot do it now (no pose yet, pose stale...)."""

    def __init__(self, message: str, reason: str = "") -> None:
        super().__init__(ErrorCode.UNAVAILABLE, message, reason)


class Internal(ZenavError):
    """The service failed while handling the request."""

    def __init__(self, message: str, reason: str = "") -> None:
        super().__init__(ErrorCode.INTERNAL, message, reason)


_ERRORS: dict[str, type[InvalidArgument | Unavailable | Internal]] = {
    ErrorCode.INVALID_ARGUMENT: InvalidArgument,
    ErrorCode.UNAVAILABLE: Unavailable,
    ErrorCode.INTERNAL: Internal,
}


def error(code: str, message: str, reason: str = "") -> ZenavError:
    """The exception of an error code (an unknown code is a plain ZenavError), chosen by the code alone."""
    typ = _ERRORS.get(code)
    return ZenavError(code, message, reason) if typ is None else typ(message, reason)


def foreign_error(data: bytes) -> ErrorCode:
    """The code of an error reply that is not the contract's ErrorReply but Zenoh's own text (b"Timeout": no reply
    came in time)."""
    return ErrorCode.UNAVAILABLE if b"timeout" in data.lower() else ErrorCode.INTERNAL


URGENT = frozenset({"nav/stop"})  # queries that travel ahead of everything else on every Zenoh link


class QueryBus(Bus, Protocol):
    """A bus that can also send queries (ZenohBus; a test's fake)."""

    def get(self, selector: str, payload: bytes | None = None, timeout: float = 5.0, urgent: bool = False) -> list[tuple[bool, bytes]]: ...

    def newest(self, key: str) -> Newest: ...


class Latest:
    """The newest message of one topic, and a way to wait for a condition on it."""

    def __init__(self) -> None:
        self._cond = threading.Condition()
        self.msg: Any = None
        self.count = 0

    def put(self, msg: Any) -> None:
        """Keep `msg` as the newest, and wake the waiters."""
        with self._cond:
            self.msg, self.count = msg, self.count + 1
            self._cond.notify_all()

    def wait(self, pred: Callable[[Any], bool] = lambda msg: msg is not None, timeout: float = 10.0) -> Any:
        """Block until pred(newest) holds; TimeoutError after `timeout` wall seconds."""
        deadline = time.monotonic() + timeout
        with self._cond:
            while not (self.msg is not None and pred(self.msg)):
                left = deadline - time.monotonic()
                if left <= 0:
                    raise TimeoutError(f"condition not met in {timeout} s (last: {self.msg!r})")
                self._cond.wait(left)
            return self.msg


class Sampled:
    """The newest message of one topic as of each read of `msg`: a view's rate, not the topic's (Client.newest,
    Service.newest). A payload that does not decode is left out (`on_bad` told of it) and the one before kept, as is a
    message `admit` refuses."""

    def __init__(
        self,
        newest: Newest,
        typ: type,
        on_bad: Callable[[codec.BadInput], None] | None = None,
        admit: Callable[[Any], bool] | None = None,
    ) -> None:
        self._newest, self._typ, self._on_bad, self._admit = newest, typ, on_bad, admit
        self._msg: Any = None

    @property
    def msg(self) -> Any:
        """The newest valid message yet (None: none came, or forgotten since)."""
        data = self._newest.take()
        if data is not None:
            try:
                msg: Any = codec.decode(data, self._typ)
            except codec.BadInput as e:
                if self._on_bad is not None:
                    self._on_bad(e)
            else:
                if self._admit is None or self._admit(msg):
                    self._msg = msg
        return self._msg

    def forget(self) -> None:
        """Drop the message kept: None until another comes."""
        self._msg = None


class Client:
    """Talk to one robot's stack through a Zenoh router."""

    def __init__(
        self,
        robot: str = "r1",
        connect: str | None = None,
        bus: QueryBus | None = None,
        connect_timeout: float | None = None,
        mode: str = "client",
    ) -> None:
        """Connect to the router at `connect` (Unavailable if none answers within `connect_timeout`),
        or talk through `bus`, which stays the caller's to close."""
        self.robot = keys.check_robot_id(robot)
        self._owned = bus is None
        if bus is None:
            try:
                bus = ZenohBus(zenoh.open(zenoh_config(mode, connect, connect_timeout=connect_timeout)))
            except zenoh.ZError as e:
                raise Unavailable(f"no Zenoh router at {connect or DEFAULT_CONNECT}: {e}") from None
        self.bus: QueryBus = bus
        self._latest: dict[str, Latest] = {}
        self._handles: list[Handle] = []  # subscriptions made through this client

    def __enter__(self) -> Client:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Withdraw this client's subscriptions and close the session it opened."""
        undeclare_all(self._handles)
        if self._owned:
            self.bus.close()

    def key(self, suffix: str) -> str:
        """The full key of a contract suffix for this robot."""
        return keys.key(self.robot, suffix)

    def query(self, suffix: str, request: dict[str, Any] | None = None, timeout: float = 5.0) -> Any:
        """Send a query; return the decoded reply or raise ZenavError.

        The request is checked against the contract first: a bad one raises
        InvalidArgument naming the field, as the service would, without a round trip.
        """
        request_type, reply_type = keys.QUERIES[suffix]
        try:
            msgspec.convert(request or {}, request_type)
        except msgspec.ValidationError as e:
            raise InvalidArgument(codec.invalid(request_type, e, request)) from None
        replies = self.bus.get(self.key(suffix), payload=codec.encode(request or {}), timeout=timeout, urgent=suffix in URGENT)
        if not replies:
            raise Unavailable(f"no reply from {self.key(suffix)} (is the service up?)")
        ok, data = replies[0]
        if not ok:
            try:
                err = codec.decode(data, m.ErrorReply)
            except codec.BadInput:
                message = f"{self.key(suffix)}: {data.decode(errors='replace')} after {timeout} s"
                raise error(foreign_error(data), message) from None
            raise error(err.error, err.message, err.reason)
        return codec.decode(data, reply_type)

    def publish(self, suffix: str, msg: Any) -> None:
        """Publish a message on a topic of this robot."""
        self.bus.publish(self.key(suffix), codec.encode(msg))

    def subscribe(self, suffix: str, callback: Callable[[Any], None], typ: type | None = None) -> Handle:
        """Call `callback(msg)` for every valid message on a topic (on Zenoh's thread: it must not block)."""
        typ = typ or keys.topic_type(suffix)

        def on_sample(key: str, data: bytes) -> None:
            try:
                callback(codec.decode(data, typ))
            except codec.BadInput:
                pass

        handle = self.bus.subscribe(self.key(suffix), on_sample)
        self._handles.append(handle)
        return handle

    def latest(self, suffix: str) -> Latest:
        """Follow a topic, keeping its newest message (subscribes once per topic)."""
        if suffix not in self._latest:
            self._latest[suffix] = Latest()
            self.subscribe(suffix, self._latest[suffix].put)
        return self._latest[suffix]

    def newest(self, suffix: str) -> Sampled:
        """Follow a topic to read its newest message now and then, at no cost per message (Latest: to wait on one)."""
        newest = self.bus.newest(self.key(suffix))
        self._handles.append(newest)
        return Sampled(newest, keys.topic_type(suffix))

    def alive(self, timeout: float = 1.0) -> set[str]:
        """The services whose liveliness token is present now."""
        return {key.rsplit("/", 1)[-1] for key in self.bus.tokens(self.key("alive/*"), timeout)}

    def wait_alive(self, services: Iterable[str], timeout: float = 30.0) -> set[str]:
        """Block until every named service has its token; TimeoutError names the missing."""
        want, seen = set(services), set[str]()
        cond = threading.Condition()

        def on_token(key: str, up: bool) -> None:
            with cond:
                name = key.rsplit("/", 1)[-1]
                (seen.add if up else seen.discard)(name)
                cond.notify_all()

        handle = self.bus.watch_tokens(self.key("alive/*"), on_token)
        deadline = time.monotonic() + timeout
        try:
            with cond:
                while not want <= seen:
                    left = deadline - time.monotonic()
                    if left <= 0:
                        raise TimeoutError(f"services not alive after {timeout} s: {', '.join(sorted(want - seen))}")
                    cond.wait(left)
                return set(seen)
        finally:
            handle.undeclare()
