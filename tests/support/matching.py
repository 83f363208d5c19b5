"""Zenoh senders that wait for a receiver, and an inbox of what a subscriber got, for tests of what arrives.

from tests.support.matching import Inbox, publish, wait_matching, wait_subscriber

wait_matching(session.declare_querier(key))   # until the querier knows a queryable of its key
wait_subscriber(bus, key)                     # until some subscriber of `key` is known to `bus`
publish(session, key, "payload")              # put once a subscriber is known
inbox = Inbox(); session.declare_subscriber(key, inbox.on_sample)
inbox.settle({(key, "payload")})              # -> every (key, payload) got, once those came and QUIET passed
"""

from __future__ import annotations

import threading

import zenoh

from zenav.common.bus import ZenohBus

QUIET = 0.5  # [s] a denied message must not arrive after the allowed ones did


def wait_matching(entity: zenoh.Publisher | zenoh.Querier, timeout: float = 10.0) -> None:
    """Block until a publisher (querier) knows a subscriber (queryable) it matches.

    So a sample or query that does not arrive was refused by the router, not
    filtered out by its sender for want of a receiver.
    """
    seen = threading.Event()
    listener = entity.declare_matching_listener(lambda status: status.matching and seen.set())
    try:
        if not (entity.matching_status.matching or seen.wait(timeout)):
            raise TimeoutError(f"nothing matches {entity.key_expr} after {timeout} s")
    finally:
        listener.undeclare()


def wait_subscriber(bus: ZenohBus, key: str, timeout: float = 10.0) -> None:
    """Block until some subscriber matches `key`: samples published before that are not delivered."""
    pub = bus.session.declare_publisher(key)
    try:
        wait_matching(pub, timeout)
    finally:
        pub.undeclare()


def publish(session: zenoh.Session, key: str, payload: str) -> None:
    """Put once the sender knows a subscriber of `key`."""
    pub = session.declare_publisher(key)
    wait_matching(pub)
    pub.put(payload)
    pub.undeclare()


class Inbox:
    """(key, payload) of every sample (or liveliness token) a subscriber receives."""

    def __init__(self) -> None:
        self.cond = threading.Condition()
        self.got: set[tuple[str, str]] = set()

    def on_sample(self, s: zenoh.Sample) -> None:
        with self.cond:
            self.got.add((str(s.key_expr), s.payload.to_bytes().decode()))
            self.cond.notify_all()

    def settle(self, expected: set[tuple[str, str]], timeout: float = 10.0) -> set[tuple[str, str]]:
        """Wait until `expected` arrived, then QUIET more seconds for anything else."""
        with self.cond:
            self.cond.wait_for(lambda: expected <= self.got, timeout)
            self.cond.wait_for(lambda: False, QUIET)  # a denied sample would be here by now
            return set(self.got)
