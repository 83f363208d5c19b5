"""The bus a service talks through: Zenoh for real, in-memory for unit and service tests.

Callbacks given to a bus run on the bus's threads (Zenoh's): they must be short and
never block (a service queues its input there, or serves a sample at once when it is
idle: runtime.Service).
"""

from __future__ import annotations

import json
import os
import threading
import time
from collections.abc import Callable, Iterable
from typing import Any, Protocol, cast

import zenoh

from zenav.common.keys import DEFAULT_CONNECT, in_loop

KEEP_ALIVES = 3  # keep-alive messages a session with a short `lease` sends per lease period
RECONNECT = {"period_init_ms": 250, "period_max_ms": 500, "period_increase_factor": 1.5}
MSGPACK = "application/msgpack"  # the Zenoh encoding of every sample and reply (zenav's codec)
JSON = "application/json"  # the encoding of replies to queries that ask `_format=json`
# [s] a peer session just opened links to the other peers (learnt from the router) a moment later, and a token lookup
# made before that misses their tokens (seen: 6 of 15 opens on a loaded 2-core host, the tokens there 15 to 32 ms
# later): for this long after opening, a peer's lookup that finds nothing looks again every LOOKUP_GAP
PEER_SETTLE = 0.2
LOOKUP_GAP = 0.01  # [s]

SampleCallback = Callable[[str, bytes], None]  # (key, payload)
TokenCallback = Callable[[str, bool], None]  # (key, alive)


class Query(Protocol):
    key: str  # the key expression the query was made on (its selector's, wildcards and all)
    payload: bytes
    params_size: int  # [bytes] of the selector parameters, known before they are parsed

    @property
    def params(self) -> dict[str, str]:
        """Selector parameters (`?x=1;y=2`), parsed on first use."""

    def reply(self, data: bytes, encoding: str = MSGPACK) -> None: ...

    def reply_err(self, data: bytes, encoding: str = MSGPACK) -> None: ...

    def finish(self) -> None:
        """No more replies: lets the querier's get() return."""


QueryCallback = Callable[[Query], None]
ReplyCallback = Callable[[bool, bytes], None]  # (ok, payload) of one reply


class Handle(Protocol):
    def undeclare(self) -> None: ...


def _matching(key: str, held: Iterable[str]) -> set[str]:
    """The keys among `held` that the key expression `key` matches."""
    ke = zenoh.KeyExpr(key)
    return {k for k in held if ke.intersects(zenoh.KeyExpr(k))}


def undeclare_all(handles: list[Handle]) -> None:
    """Undeclare every handle, newest first, and empty the list (a closed session is no error)."""
    for handle in reversed(handles):
        try:
            handle.undeclare()
        except Exception:  # the session may be closed already
            pass
    handles.clear()


class Newest(Protocol):
    """The newest sample of a subscription, taken when asked (no callback per sample)."""

    def take(self) -> bytes | None:
        """The newest payload that came since the last take (None: none came)."""

    def undeclare(self) -> None: ...


class Bus(Protocol):
    def publish(self, key: str, data: bytes) -> None: ...

    def subscribe(self, key: str, callback: SampleCallback) -> Handle: ...

    def newest(self, key: str) -> Newest:
        """Keep the newest sample of `key` for whoever takes it (no callback of the caller's per sample)."""

    def queryable(self, key: str, callback: QueryCallback, urgent: bool = False) -> Handle:
        """Serve queries on `key`. `urgent` (nav/stop): on a link of its own where the bus has links,
        so the query never waits behind other input still on the wire."""

    def request(self, key: str, payload: bytes, callback: ReplyCallback, timeout: float = 1.0) -> None:
        """Query `key` without waiting: `callback(ok, payload)` runs for each reply on the bus's thread (only enqueue there)."""

    def token(self, key: str) -> Handle: ...

    def watch_tokens(self, key: str, callback: TokenCallback) -> Handle: ...

    def tokens(self, key: str, timeout: float = 2.0) -> list[str]:
        """Keys of the liveliness tokens matching `key` that are declared now (this bus's own too), sorted, each once."""

    def close(self) -> None: ...


# ------------------------------------------------------------------ in memory
class _MemHandle:
    def __init__(self, table: list[Any], entry: tuple[Any, ...]) -> None:
        self._table, self._entry = table, entry

    def undeclare(self) -> None:
        if self._entry in self._table:
            self._table.remove(self._entry)


class Subscribed:
    """Newest through a plain subscription (a bus with no buffer of its own: in memory, a test's fake)."""

    def __init__(self, bus: Bus, key: str) -> None:
        self._data: bytes | None = None
        self._handle = bus.subscribe(key, self._put)

    def _put(self, key: str, data: bytes) -> None:
        self._data = data

    def take(self) -> bytes | None:
        data, self._data = self._data, None
        return data

    def undeclare(self) -> None:
        self._handle.undeclare()


class MemoryQuery:
    """A query on the in-memory bus; its replies are kept for the test to read."""

    def __init__(self, key: str, payload: bytes = b"", params: dict[str, str] | None = None, on_reply: ReplyCallback | None = None) -> None:
        self.key, self.payload, self.params, self.on_reply = key, payload, dict(params or {}), on_reply
        self.params_size = sum(len(k) + len(v) + 2 for k, v in self.params.items())
        self.replies: list[tuple[bool, bytes]] = []  # (ok, payload)
        self.encodings: list[str] = []  # the Zenoh encoding of each reply
        self.finished = False

    def reply(self, data: bytes, encoding: str = MSGPACK) -> None:
        self.replies.append((True, data))
        self.encodings.append(encoding)
        if self.on_reply is not None:
            self.on_reply(True, data)

    def reply_err(self, data: bytes, encoding: str = MSGPACK) -> None:
        self.replies.append((False, data))
        self.encodings.append(encoding)
        if self.on_reply is not None:
            self.on_reply(False, data)

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

    def newest(self, key: str) -> Newest:
        return Subscribed(self, key)

    def queryable(self, key: str, callback: QueryCallback, urgent: bool = False) -> Handle:
        entry = (zenoh.KeyExpr(key), callback)
        self._queryables.append(entry)
        return _MemHandle(self._queryables, entry)

    def query(
        self, key: str, payload: bytes = b"", params: dict[str, str] | None = None, on_reply: ReplyCallback | None = None
    ) -> MemoryQuery:
        """Send a query; the returned object collects the replies (and passes each to `on_reply`)."""
        q = MemoryQuery(key, payload, params, on_reply)
        ke = zenoh.KeyExpr(key)
        for expr, cb in list(self._queryables):
            if expr.intersects(ke):
                cb(q)
        return q

    def request(self, key: str, payload: bytes, callback: ReplyCallback, timeout: float = 1.0) -> None:
        self.query(key, payload, on_reply=callback)

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

    def tokens(self, key: str, timeout: float = 2.0) -> list[str]:
        return sorted(_matching(key, (k for (k,) in self._tokens)))

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
    connect: str | None = None,
    listen: str | None = None,
    config_file: str | None = None,
    connect_timeout: float | None = None,
    lease: float | None = None,
    max_message: int | None = None,
) -> zenoh.Config:
    """A Zenoh config: client of `connect`, a router on `listen`, or a peer that
    connects to `connect`, listens on `listen` and links directly with the other peers.

    A client (or peer) waits for its router forever (services: the router may come later),
    or fails after `connect_timeout` seconds (tools a person is waiting on).

    `config_file` (or $ZENOH_CONFIG) is a full Zenoh JSON5 config to start from,
    for deployments with auth or access control.

    `lease` [s]: the transport lease this session announces (Zenoh's default: 10 s).
    The router closes the session, and withdraws its liveliness tokens, when it has
    heard nothing from it for that long: a frozen process (SIGSTOP, a hung laptop, a
    dropped Wi-Fi link) loses its tokens within `lease`, not 10 s. Keep-alives go
    out KEEP_ALIVES times per lease.

    `max_message` [bytes]: the largest message taken off a link (Zenoh's
    transport/link/rx/max_message_size, default 1 GiB); a larger one is dropped by Zenoh
    as it arrives, before it is handed to any subscriber or queryable.
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
    if lease is not None:
        conf.insert_json5("transport/link/tx/lease", json.dumps(round(lease * 1000)))
        conf.insert_json5("transport/link/tx/keep_alive", json.dumps(KEEP_ALIVES))
    if max_message is not None:
        conf.insert_json5("transport/link/rx/max_message_size", json.dumps(max_message))
    if listen:
        conf.insert_json5("listen", json.dumps({"endpoints": [e for e in listen.split(",") if e]}))
    return cast(zenoh.Config, conf)


def _direct(fn: Callable[[Any], None]) -> zenoh.handlers.Callback[Any]:
    """Run `fn` on Zenoh's network thread, in arrival order across all of a session's
    subscriptions. (Zenoh's default runs each callback on a thread of its own, so two
    topics from one publisher could be enqueued out of order.) Safe because zenav's
    callbacks are short and never block: they queue, or run one sample's handler."""
    return cast("zenoh.handlers.Callback[Any]", zenoh.handlers.Callback(fn, indirect=False))


_MSGPACK = zenoh.Encoding(MSGPACK)


class _ZToken:
    """A liveliness token and its key, which its bus lists among its own while it is declared."""

    def __init__(self, token: zenoh.LivelinessToken, key: str) -> None:
        self._token: zenoh.LivelinessToken | None = token
        self.key = key

    @property
    def declared(self) -> bool:
        return self._token is not None

    def undeclare(self) -> None:
        token, self._token = self._token, None
        if token is not None:
            token.undeclare()


class _ZQuery:
    """A Zenoh query as the runtime sees it; replies are sent on the queryable's own key."""

    def __init__(self, q: zenoh.Query, own_key: str) -> None:
        self._q, self._own = q, own_key
        self.key = str(q.key_expr)
        self._raw = str(q.parameters)
        self.params_size = len(self._raw)
        self._params: dict[str, str] | None = None
        self.payload = q.payload.to_bytes() if q.payload is not None else b""

    @property
    def params(self) -> dict[str, str]:
        if self._params is None:
            self._params = dict(cast(Any, self._q.parameters))
        return self._params

    def reply(self, data: bytes, encoding: str = MSGPACK) -> None:
        self._q.reply(self._own, data, encoding=zenoh.Encoding(encoding))

    def reply_err(self, data: bytes, encoding: str = MSGPACK) -> None:
        self._q.reply_err(data, encoding=zenoh.Encoding(encoding))

    def finish(self) -> None:
        self._q.drop()


class _ZNewest:
    def __init__(self, sub: zenoh.Subscriber[Any]) -> None:
        self._sub = sub

    def take(self) -> bytes | None:
        sample = self._sub.try_recv()
        return None if sample is None else sample.payload.to_bytes()

    def undeclare(self) -> None:
        self._sub.undeclare()


class ZenohBus:
    """A bus on one Zenoh session (closed with the bus), and for urgent queryables a second one.

    A link carries its samples in order: a stop sent while megabytes of goals from another
    client are on their way to this process (in the router's queue and the sockets) would
    arrive after them, Zenoh's real-time priority notwithstanding. Urgent queryables are
    declared on a second session, opened like the first on the first such declaration: a
    link of its own to the router that nothing else fills."""

    def __init__(self, session: zenoh.Session, reopen: Callable[[], zenoh.Session] | None = None, settle: float = 0.0) -> None:
        self.session = session
        self._settled = time.monotonic() + settle  # [s] monotonic: token lookups until then look again (PEER_SETTLE)
        self._reopen = reopen  # opens another session like this one (None: urgent queryables share it)
        self._urgent: zenoh.Session | None = None
        self._pubs: dict[str, zenoh.Publisher] = {}
        self._lock = threading.Lock()
        self._handles: list[Any] = []

    @classmethod
    def open(
        cls,
        connect: str | None = None,
        mode: str = "client",
        listen: str | None = None,
        connect_timeout: float | None = None,
        lease: float | None = None,
        max_message: int | None = None,
    ) -> ZenohBus:
        """Open a session (zenoh.ZError if `connect_timeout` passes with no router); `lease` and `max_message` as in zenoh_config."""

        def make() -> zenoh.Session:
            return zenoh.open(zenoh_config(mode, connect, listen, connect_timeout=connect_timeout, lease=lease, max_message=max_message))

        return cls(make(), reopen=make, settle=PEER_SETTLE if mode == "peer" else 0.0)

    def publish(self, key: str, data: bytes) -> None:
        pub = self._pubs.get(key)
        if pub is None:
            with self._lock:
                pub = self._pubs.get(key)
                if pub is None:
                    # Small messages at 100 Hz: send at once (express) and never drop
                    # silently under load (BLOCK); a dropped wheel command is a hazard.
                    # The robot's loop goes ahead of bulk data queued on a link.
                    # Camera frames are the exception: a link that cannot take one (a host whose cable is out)
                    # drops it, a newer frame follows, and the sender's loop is never held up behind it.
                    priority = zenoh.Priority.INTERACTIVE_HIGH if in_loop(key) else zenoh.Priority.DEFAULT
                    congestion = zenoh.CongestionControl.DROP if key.endswith("/frame") else zenoh.CongestionControl.BLOCK
                    pub = self.session.declare_publisher(
                        key, encoding=_MSGPACK, congestion_control=congestion, express=True, priority=priority
                    )
                    self._pubs[key] = pub
        pub.put(data)

    def subscribe(self, key: str, callback: SampleCallback) -> Handle:
        def on_sample(s: zenoh.Sample) -> None:
            callback(str(s.key_expr), s.payload.to_bytes())

        def on_own_key(s: zenoh.Sample) -> None:  # a key with no wildcard: every sample's is that one
            callback(key, s.payload.to_bytes())

        wildcard = "*" in key or "$" in key
        h = self.session.declare_subscriber(key, _direct(on_sample if wildcard else on_own_key))
        self._handles.append(h)
        return h

    def newest(self, key: str) -> Newest:
        """Keep the newest sample of `key` in Zenoh's own one-slot buffer: no Python runs per sample, for a
        view that reads a 100 Hz topic at its own slow rate (the screen of `zenav up`, on the robot's computer)."""
        sub = self.session.declare_subscriber(key, zenoh.handlers.RingChannel(1))
        self._handles.append(sub)
        return _ZNewest(sub)

    def queryable(self, key: str, callback: QueryCallback, urgent: bool = False) -> Handle:
        session = self.session
        if urgent and self._reopen is not None:
            with self._lock:
                if self._urgent is None:
                    self._urgent = self._reopen()
                session = self._urgent
        h = session.declare_queryable(key, _direct(lambda q: callback(_ZQuery(q, key))))
        self._handles.append(h)
        return h

    def token(self, key: str) -> Handle:
        h = _ZToken(self.session.liveliness().declare_token(key), key)
        self._handles.append(h)
        return h

    def watch_tokens(self, key: str, callback: TokenCallback) -> Handle:
        def on_sample(s: zenoh.Sample) -> None:
            callback(str(s.key_expr), s.kind == zenoh.SampleKind.PUT)

        h = self.session.liveliness().declare_subscriber(key, _direct(on_sample), history=True)
        self._handles.append(h)
        return h

    def tokens(self, key: str, timeout: float = 2.0) -> list[str]:
        # Zenoh answers a session's query for its own token zero to two times (its own reply, the router's
        # echo): that part comes from what this bus holds
        found = self._lookup(key, timeout)
        while not found and time.monotonic() < self._settled:  # a young peer: the links to the others may still be forming
            time.sleep(LOOKUP_GAP)
            found = self._lookup(key, timeout)
        held = [h.key for h in list(self._handles) if isinstance(h, _ZToken) and h.declared]  # a copy: handles come meanwhile
        return sorted(found | _matching(key, held))

    def _lookup(self, key: str, timeout: float) -> set[str]:
        return {str(r.ok.key_expr) for r in self.session.liveliness().get(key, timeout=timeout) if r.ok is not None}

    def request(self, key: str, payload: bytes, callback: ReplyCallback, timeout: float = 1.0) -> None:
        def on_reply(rep: zenoh.Reply) -> None:
            if rep.ok is not None:
                callback(True, rep.ok.payload.to_bytes())
            elif rep.err is not None:
                callback(False, rep.err.payload.to_bytes())

        self.session.get(key, _direct(on_reply), payload=payload, timeout=timeout)

    def get(self, selector: str, payload: bytes | None = None, timeout: float = 5.0, urgent: bool = False) -> list[tuple[bool, bytes]]:
        """Query and collect the replies as (ok, payload) pairs.

        An `urgent` query (nav/stop) goes at Zenoh's real-time priority: on every link it
        overtakes data already queued there (large goals from other clients, say).
        """
        out = []
        priority = zenoh.Priority.REAL_TIME if urgent else zenoh.Priority.DEFAULT
        for rep in self.session.get(selector, payload=payload, timeout=timeout, priority=priority):
            if rep.ok is not None:
                out.append((True, rep.ok.payload.to_bytes()))
            elif rep.err is not None:
                out.append((False, rep.err.payload.to_bytes()))
        return out

    def close(self) -> None:
        for session in (self._urgent, self.session):
            if session is not None and not session.is_closed():
                session.close()
