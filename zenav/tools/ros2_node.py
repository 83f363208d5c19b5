"""One ROS 2 node on rmw_zenoh's wire, on a Zenoh session: its graph tokens, publishers, subscriptions, services.

Names and layouts are tools/rmw_zenoh.py's. Subscriptions and services listen on their key with
any type hash (Wire.any_hash_key) and take samples with or without rmw_zenoh's attachment.
Callbacks run on Zenoh's threads: the caller's must only enqueue.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable
from typing import Any

import zenoh
import zenoh.ext

from zenav.common.bus import undeclare_all
from zenav.tools.rmw_zenoh import TRANSIENT_LOCAL, Endpoint, Wire, attachment, gid, parse_attachment

Incoming = Callable[[bytes], None]  # a sample's payload
QueryCallback = Callable[[zenoh.Query], None]


class Publisher:
    """One ROS publisher: its rmw_zenoh key, GID and sequence numbers.

    A transient local one (a latched topic: a map, an action's status) keeps its last `depth`
    samples for subscribers that come later, both ways rmw_zenoh's subscriptions ask for them:
    a Zenoh advanced publisher's cache (rmw_zenoh on zenoh 1.1 and later) and a queryable on
    `<session id>/<key>`, the publication cache of earlier releases, answered on the key itself.
    """

    def __init__(self, session: zenoh.Session, wire: Wire, ep: Endpoint, token: str) -> None:
        self.ros_type, self.key, self.gid, self.seq = ep.ros_type, wire.key(ep), gid(token), 0
        self.wire, self._lock = wire, threading.Lock()
        self._latched: deque[tuple[bytes, bytes]] | None = None  # (payload, attachment) of the last samples
        self._handles: list[Any] = []
        if ep.durability == TRANSIENT_LOCAL:
            self._latched = deque(maxlen=max(1, ep.depth))
            self._pub: Any = zenoh.ext.declare_advanced_publisher(
                session,
                self.key,
                encoding=zenoh.Encoding.APPLICATION_CDR,
                cache=zenoh.ext.CacheConfig(max(1, ep.depth)),
                sample_miss_detection=zenoh.ext.MissDetectionConfig(
                    heartbeat=None, sporadic_heartbeat=None
                ),  # sequence numbers, not timestamps
                publisher_detection=True,
            )
            self._cache_key = f"{session.zid()}/{self.key}"
            self._handles.append(session.declare_queryable(self._cache_key, self._history, complete=True))
        else:
            self._pub = session.declare_publisher(self.key, encoding=zenoh.Encoding.APPLICATION_CDR)

    def put(self, msg: Any) -> None:
        """Serialize and publish one message (from any thread: the sequence numbers stay in order)."""
        data = self.wire.serialize(msg, self.ros_type)
        with self._lock:
            self.seq += 1
            extra = attachment(self.seq, time.time_ns(), self.gid)
            if self._latched is not None:
                self._latched.append((data, extra))
            self._pub.put(data, attachment=extra)

    def _history(self, query: zenoh.Query) -> None:
        """A late subscription's query: the kept samples, on the topic's key (a Zenoh thread: no waiting).
        A query that takes replies on matching keys only (not a querying subscriber's) gets them on the cache's key."""
        with self._lock:
            kept = list(self._latched or ())
        key = self.key if query.accepts_replies() == zenoh.ReplyKeyExpr.ANY else self._cache_key
        try:
            for data, extra in kept:
                query.reply(key, data, encoding=zenoh.Encoding.APPLICATION_CDR, attachment=extra)
        finally:
            query.drop()

    def undeclare(self) -> None:
        undeclare_all(self._handles)
        self._pub.undeclare()


class Node:
    """A ROS node's presence on the wire: declare its endpoints, then close()."""

    def __init__(self, session: zenoh.Session, wire: Wire) -> None:
        self.session, self.wire = session, wire
        self.zid = str(session.zid())
        self.endpoints: list[Endpoint] = []
        self._handles: list[Any] = [session.liveliness().declare_token(wire.node_token(self.zid))]
        self._server_gid = gid(wire.node_token(self.zid))

    def _declare(self, ep: Endpoint) -> str:
        self.endpoints.append(ep)
        token = self.wire.token(self.zid, ep, len(self.endpoints))
        self._handles.append(self.session.liveliness().declare_token(token))
        return token

    def publisher(self, name: str, ros_type: str, depth: int = 10, durability: int | None = None) -> Publisher:
        """A publisher (MP) on topic `name` (relative names go under the node's namespace)."""
        ep = self.wire.endpoint("MP", name, ros_type, depth, durability)
        pub = Publisher(self.session, self.wire, ep, self._declare(ep))
        self._handles.append(pub)
        return pub

    def subscription(self, name: str, ros_type: str, callback: Incoming, depth: int = 10) -> None:
        """A subscription (MS) on topic `name`: `callback(payload)` for each sample, whatever its type hash."""
        ep = self.wire.endpoint("MS", name, ros_type, depth)
        self._declare(ep)
        self._handles.append(self.session.declare_subscriber(self.wire.any_hash_key(ep), lambda s: callback(s.payload.to_bytes())))

    def service(self, name: str, srv_type: str, callback: QueryCallback) -> None:
        """A service server (SS) on `name`: `callback(query)` for each request; answer with reply()."""
        ep = self.wire.endpoint("SS", name, srv_type)
        self._declare(ep)
        self._handles.append(self.session.declare_queryable(self.wire.any_hash_key(ep), callback, complete=True))

    def reply(self, query: zenoh.Query, msg: Any, ros_type: str) -> None:
        """Answer a request with `msg`, echoing its sequence number and client GID as rmw_zenoh does; then finish it."""
        seq, client = 0, self._server_gid
        if query.attachment is not None:
            try:
                seq, _, client = parse_attachment(query.attachment.to_bytes())
            except ValueError:
                pass  # a request without rmw_zenoh's attachment gets the node's own GID
        data = self.wire.serialize(msg, ros_type)
        try:
            query.reply(query.key_expr, data, encoding=zenoh.Encoding.APPLICATION_CDR, attachment=attachment(seq, time.time_ns(), client))
        finally:
            query.drop()

    def close(self) -> None:
        """Withdraw every token, publisher, subscription and service."""
        undeclare_all(self._handles)


def request(query: zenoh.Query) -> bytes:
    """A request's payload (empty if none)."""
    return b"" if query.payload is None else query.payload.to_bytes()
