"""What goes first on a link: an urgent queryable (nav/stop) answers from a session of its own, a link to the router
that other input cannot fill; the robot's loop topics are published at a higher priority than bulk data."""

from __future__ import annotations

import queue

import zenoh

from tests.support.matching import wait_matching, wait_subscriber
from zenav.common.bus import Query, ZenohBus


def answer(payload: bytes):
    def on_query(q: Query) -> None:
        q.reply(payload)
        q.finish()

    return on_query


def test_an_urgent_queryable_answers_from_its_own_session(router):
    bus, asker = ZenohBus.open(router, connect_timeout=5.0), ZenohBus.open(router, connect_timeout=5.0)
    try:
        bus.queryable("zenav/r1/plain", answer(b"plain"))
        bus.queryable("zenav/r1/urgent", answer(b"urgent"), urgent=True)
        repliers = {}
        for key in ("plain", "urgent"):
            querier = asker.session.declare_querier(f"zenav/r1/{key}", timeout=5.0)
            wait_matching(querier)
            [reply] = list(querier.get())
            assert reply.ok is not None and reply.ok.payload.to_bytes() == key.encode()
            repliers[key] = str(reply.replier_id.zid)
            querier.undeclare()
        assert repliers["plain"] == str(bus.session.zid())
        assert repliers["urgent"] != repliers["plain"]  # the second session's
    finally:
        bus.close()
        asker.close()


def test_the_loop_travels_ahead_of_bulk_data(router):
    """cmd_vel and the rest of the robot's loop go at interactive-high priority, so a router forwards them ahead of
    bulk data queued on a link; everything else at the default."""
    bus, listener = ZenohBus.open(router, connect_timeout=5.0), ZenohBus.open(router, connect_timeout=5.0)
    got: queue.Queue = queue.Queue()
    try:
        listener.session.declare_subscriber("zenav/**", lambda s: got.put((str(s.key_expr), s.priority)))
        sent = ["zenav/r1/cmd_vel", "zenav/r1/sensors/encoders", "zenav/r1/nav/state", "zenav/field/camera/frame"]
        for key in sent:
            wait_subscriber(bus, key)
            bus.publish(key, b"\x80")
        seen = dict(got.get(timeout=5.0) for _ in sent)
        assert seen == {
            "zenav/r1/cmd_vel": zenoh.Priority.INTERACTIVE_HIGH,
            "zenav/r1/sensors/encoders": zenoh.Priority.INTERACTIVE_HIGH,
            "zenav/r1/nav/state": zenoh.Priority.DATA,
            "zenav/field/camera/frame": zenoh.Priority.DATA,
        }
    finally:
        bus.close()
        listener.close()
