"""A client of a running stack: queries, subscriptions and liveliness (CLI, tests, bench)."""
from __future__ import annotations

import threading
import time
from typing import Any, Callable, Iterable, Optional

from zenav.common import codec, keys
from zenav.common import messages as m
import zenoh

from zenav.common.bus import DEFAULT_CONNECT, ZenohBus


class ClientError(Exception):
    """An error reply (`code` is the contract's error code) or no reply at all."""

    def __init__(self, code: str, message: str) -> None:
        super().__init__(f"{code}: {message}")
        self.code, self.message = code, message


class Latest:
    """The newest message of one topic, and a way to wait for a condition on it."""

    def __init__(self) -> None:
        self._cond = threading.Condition()
        self.msg: Any = None
        self.count = 0

    def put(self, msg: Any) -> None:
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


class Client:
    """Talk to one robot's stack through a Zenoh router."""

    def __init__(
        self, robot: str = "r1", connect: Optional[str] = None, bus: Optional[ZenohBus] = None, connect_timeout: Optional[float] = None
    ) -> None:
        """Connect to the router at `connect`; with `connect_timeout`, ClientError `unavailable` if none answers."""
        self.robot = keys.check_robot_id(robot)
        if bus is None:
            try:
                bus = ZenohBus.open(connect, connect_timeout=connect_timeout)
            except zenoh.ZError as e:
                raise ClientError("unavailable", f"no Zenoh router at {connect or DEFAULT_CONNECT}: {e}") from None
        self.bus = bus
        self._latest: dict[str, Latest] = {}

    def __enter__(self) -> Client:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        self.bus.close()

    def key(self, suffix: str) -> str:
        return keys.key(self.robot, suffix)

    def query(self, suffix: str, request: Optional[dict] = None, timeout: float = 5.0) -> Any:
        """Send a query; return the decoded reply or raise ClientError."""
        _, reply_type = keys.QUERIES[suffix]
        payload = codec.encode(request or {})
        replies = self.bus.get(self.key(suffix), payload=payload, timeout=timeout)
        if not replies:
            raise ClientError("unavailable", f"no reply from {self.key(suffix)} (is the service up?)")
        ok, data = replies[0]
        if not ok:
            try:
                err = codec.decode(data, m.ErrorReply)
            except codec.BadInput:
                # Not a zenav error map: Zenoh's own, e.g. b"Timeout" when no reply came in time.
                code = "unavailable" if b"timeout" in data.lower() else "internal"
                raise ClientError(code, f"{self.key(suffix)}: {data.decode(errors='replace')} after {timeout} s") from None
            raise ClientError(err.error, err.message)
        return codec.decode(data, reply_type)

    def publish(self, suffix: str, msg: Any) -> None:
        self.bus.publish(self.key(suffix), codec.encode(msg))

    def subscribe(self, suffix: str, callback: Callable[[Any], None], typ: Optional[type] = None) -> None:
        """Call `callback(msg)` for every valid message on a topic (on Zenoh's thread)."""
        typ = typ or keys.TOPICS[suffix]

        def on_sample(key: str, data: bytes) -> None:
            try:
                callback(codec.decode(data, typ))
            except codec.BadInput:
                pass

        self.bus.subscribe(self.key(suffix), on_sample)

    def latest(self, suffix: str) -> Latest:
        """Follow a topic, keeping its newest message (subscribes once per topic)."""
        if suffix not in self._latest:
            self._latest[suffix] = Latest()
            self.subscribe(suffix, self._latest[suffix].put)
        return self._latest[suffix]

    def alive(self, timeout: float = 1.0) -> set[str]:
        """The services whose liveliness token is present now."""
        names = set()
        for rep in self.bus.session.liveliness().get(self.key("alive/*"), timeout=timeout):
            if rep.ok is not None:
                names.add(str(rep.ok.key_expr).rsplit("/", 1)[-1])
        return names

    def wait_alive(self, services: Iterable[str] = keys.SERVICES, timeout: float = 30.0) -> set[str]:
        """Block until every named service has its token; TimeoutError names the missing."""
        want, seen = set(services), set()
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
