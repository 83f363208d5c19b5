"""An urgent queryable (nav/stop) answers from a session of its own: a link to the router that other input cannot fill."""

from __future__ import annotations

from tests.support.matching import wait_matching
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
