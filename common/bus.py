"""The bus a service talks through: Zenoh for real, in-memory for unit and service tests.

Callbacks given to a bus run on the bus's threads (Zenoh's) and must only enqueue.
"""
from __future__ import annotations

import json
import os
import threading
from typing import Callable, Optional, Protocol

import zenoh

DEFAULT_CONNECT = "tcp/127.0.0.1:7447"
RECONNECT = {"period_init_ms": 250, "period_max_ms": 500, "period_increase_factor": 1.5}

SampleCallback = Callable[[str, bytes], None]  # (key, payload)
TokenCallback = Callable[[str, bool], None]  # (key, alive)


class Query(Protocol):
    key: str  # the key the query was made on
    params: dict[str, str]  # selector parameters (`?x=1;y=2`)
    payload: bytes

    def reply(self, data: bytes) -> None: ...

    def reply_err(self, data: bytes) -> None: ...

    def finish(self) -> None:
        """No more replies: lets the querier's get() return."""


QueryCallback = Callable[[Query], None]


class Handle(Protocol):
    def undeclare(self) -> None: ...


class Bus(Protocol):
    def publish(self, key: str, data: bytes) -> None: ...

    def subscribe(self, key: str, callback: SampleCallback) -> Handle: ...

    def queryable(self, key: str, callback: QueryCallback) -> Handle: ...

    def token(self, key: str) -> Handle: ...

    def watch_tokens(self, key: str, callback: TokenCallback) -> Handle: ...

    def close(self) -> None: ...


# ------------------------------------------------------------------ in memory
class _MemHandle:
    def __init__(self, table: list, entry: tuple) -> None:
        self._table, self._entry = table, entry

    def undeclare(self) -> None:
        if self._entry in self._table:
            self._table.remove(self._entry)


class MemoryQuery:
    """A query on the in-memory bus; its replies are kept for the test to read."""

    def __init__(self, key: str, payload: bytes = b"", params: Optional[dict[str, str]] = None) -> None:
        self.key, self.payload, self.params = key, payload, dict(params or {})
        self.replies: list[tuple[bool, bytes]] = []  # (ok, payload)
        self.finished = False

    def reply(self, data: bytes) -> None:
        self.replies.append((True, data))

    def reply_err(self, data: bytes) -> None:
        self.replies.append((False, data))

    def finish(self) -> None:
        self.finished = True


class MemoryBus:
    """Delivers synchronously in the caller's thread, matching keys as Zenoh does."""

    def __init__(self) -> None:
        self._subs: list[tuple[zenoh.KeyExpr, SampleCallback]] = []
        self._queryables: list[tuple[zenoh.KeyExpr, QueryCallback]] = []
        self._tokens: list[tuple[str]] = []
        self._watchers: list[tuple[zenoh.KeyExpr, TokenCallback]] = []
        self.published: list[tuple[str, bytes]] = []  # every put, for tests to inspect

    def publish(self, key: str, data: bytes) -> None:
        self.published.append((key, data))
        ke = zenoh.KeyExpr(key)
        for expr, cb in list(self._subs):
            if expr.intersects(ke):
                cb(key, data)

    def subscribe(self, key: str, callback: SampleCallback) -> Handle:
        entry = (zenoh.KeyExpr(key), callback)
        self._subs.append(entry)
        return _MemHandle(self._subs, entry)

    def queryable(self, key: str, callback: QueryCallback) -> Handle:
        entry = (zenoh.KeyExpr(key), callback)
        self._queryables.append(entry)
        return _MemHandle(self._queryables, entry)

    def query(self, key: str, payload: bytes = b"", params: Optional[dict[str, str]] = None) -> MemoryQuery:
        """Send a query; the returned object collects the replies."""
        q = MemoryQuery(key, payload, params)
        ke = zenoh.KeyExpr(key)
        for expr, cb in list(self._queryables):
            if expr.intersects(ke):
                cb(q)
        return q

    def token(self, key: str) -> Handle:
        entry = (key,)
        self._tokens.append(entry)
        self._notify(key, True)
        bus = self

        class _Tok:
            def undeclare(self) -> None:
                if entry in bus._tokens:
                    bus._tokens.remove(entry)
                    bus._notify(key, False)

        return _Tok()

    def alive(self) -> list[str]:
        """Keys of the tokens currently declared."""
        return [k for (k,) in self._tokens]

    def watch_tokens(self, key: str, callback: TokenCallback) -> Handle:
        entry = (zenoh.KeyExpr(key), callback)
        self._watchers.append(entry)
        for (k,) in self._tokens:
            if entry[0].intersects(zenoh.KeyExpr(k)):
                callback(k, True)
        return _MemHandle(self._watchers, entry)

    def _notify(self, key: str, alive: bool) -> None:
        ke = zenoh.KeyExpr(key)
        for expr, cb in list(self._watchers):
            if expr.intersects(ke):
                cb(key, alive)

    def close(self) -> None:
        self._subs.clear()
        self._queryables.clear()


# ------------------------------------------------------------------ zenoh
def zenoh_config(
    mode: str = "client",
    connect: Optional[str] = None,
    listen: Optional[str] = None,
    config_file: Optional[str] = None,
    connect_timeout: Optional[float] = None,
) -> zenoh.Config:
    """A Zenoh config: client of `connect`, a router on `listen`, or a peer that
    connects to `connect`, listens on `listen` and links directly with the other peers.

    A client (or peer) waits for its router forever (services: the router may come later),
    or fails after `connect_timeout` seconds (tools a person is waiting on).

    `config_file` (or $ZENOH_CONFIG) is a full Zenoh JSON5 config to start from,
    for deployments with auth or access control.
    """
    path = config_file or os.environ.get("ZENOH_CONFIG")
    conf = zenoh.Config.from_file(path) if path else zenoh.Config()
    conf.insert_json5("mode", json.dumps(mode))
    # Loopback and explicit endpoints only: no multicast discovery of strangers.
    # Routers and peers gossip, so peers learn each other's endpoints through the router and link directly.
    conf.insert_json5("scouting", json.dumps({"multicast": {"enabled": False}, "gossip": {"enabled": mode != "client"}}))
    endpoints = [e for e in (connect or "").split(",") if e]
    if mode != "router" or endpoints:
        endpoints = endpoints or [DEFAULT_CONNECT]
        timeout_ms = -1 if connect_timeout is None else int(connect_timeout * 1000)
        connect_conf = {
            "endpoints": endpoints,
            "timeout_ms": timeout_ms,
            "exit_on_failure": connect_timeout is not None,
            # Look for a lost router every 0.5 s at most (Zenoh's default backs off to
            # 4 s), so services are back within a second of the router's return.
            "retry": RECONNECT,
        }
        conf.insert_json5("connect", json.dumps(connect_conf))
    if listen:
        conf.insert_json5("listen", json.dumps({"endpoints": [e for e in listen.split(",") if e]}))
    return conf


def _direct(fn: Callable) -> zenoh.handlers.Callback:
    """Run `fn` on Zenoh's network thread, in arrival order across all of a session's
    subscriptions. (Zenoh's default runs each callback on a thread of its own, so two
    topics from one publisher could be enqueued out of order.) Safe because every
    zenav callback only enqueues."""
    return zenoh.handlers.Callback(fn, indirect=False)


class _ZQuery:
    def __init__(self, q: zenoh.Query) -> None:
        self._q = q
        self.key = str(q.key_expr)
        self.params = dict(q.parameters)
        self.payload = q.payload.to_bytes() if q.payload is not None else b""

    def reply(self, data: bytes) -> None:
        self._q.reply(self._q.key_expr, data)

    def reply_err(self, data: bytes) -> None:
        self._q.reply_err(data)

    def finish(self) -> None:
        self._q.drop()


class ZenohBus:
    """A bus on one Zenoh session (closed with the bus)."""

    def __init__(self, session: zenoh.Session) -> None:
        self.session = session
        self._pubs: dict[str, zenoh.Publisher] = {}
        self._lock = threading.Lock()
        self._handles: list = []

    @classmethod
    def open(
        cls, connect: Optional[str] = None, mode: str = "client", listen: Optional[str] = None, connect_timeout: Optional[float] = None
    ) -> ZenohBus:
        """Open a session (zenoh.ZError if `connect_timeout` passes with no router)."""
        return cls(zenoh.open(zenoh_config(mode, connect, listen, connect_timeout=connect_timeout)))

    def publish(self, key: str, data: bytes) -> None:
        pub = self._pubs.get(key)
        if pub is None:
            with self._lock:
                pub = self._pubs.get(key)
                if pub is None:
                    # Small messages at 100 Hz: send at once (express) and never drop
                    # silently under load (BLOCK); a dropped wheel command is a hazard.
                    pub = self.session.declare_publisher(
                        key, congestion_control=zenoh.CongestionControl.BLOCK, express=True
                    )
                    self._pubs[key] = pub
        pub.put(data)

    def subscribe(self, key: str, callback: SampleCallback) -> Handle:
        def on_sample(s: zenoh.Sample) -> None:
            callback(str(s.key_expr), s.payload.to_bytes())

        h = self.session.declare_subscriber(key, _direct(on_sample))
        self._handles.append(h)
        return h

    def queryable(self, key: str, callback: QueryCallback) -> Handle:
        h = self.session.declare_queryable(key, _direct(lambda q: callback(_ZQuery(q))))
        self._handles.append(h)
        return h

    def token(self, key: str) -> Handle:
        h = self.session.liveliness().declare_token(key)
        self._handles.append(h)
        return h

    def watch_tokens(self, key: str, callback: TokenCallback) -> Handle:
        def on_sample(s: zenoh.Sample) -> None:
            callback(str(s.key_expr), s.kind == zenoh.SampleKind.PUT)

        h = self.session.liveliness().declare_subscriber(key, _direct(on_sample), history=True)
        self._handles.append(h)
        return h

    def get(self, selector: str, payload: Optional[bytes] = None, timeout: float = 5.0) -> list[tuple[bool, bytes]]:
        """Query and collect the replies as (ok, payload) pairs."""
        out = []
        for rep in self.session.get(selector, payload=payload, timeout=timeout):
            if rep.ok is not None:
                out.append((True, rep.ok.payload.to_bytes()))
            else:
                out.append((False, rep.err.payload.to_bytes()))
        return out

    def close(self) -> None:
        if not self.session.is_closed():
            self.session.close()
