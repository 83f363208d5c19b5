"""Bus.tokens through a real router: each declared token once, the session's own included. Zenoh answers a
session's query for its own token zero to two times (its local reply, the router's echo)."""

from __future__ import annotations

import threading

from zenav.common.bus import ZenohBus

WAIT = 10.0


def test_a_bus_lists_its_own_tokens_once_each_query_and_another_sessions_too(router):
    mine, other, witness = (ZenohBus.open(router, connect_timeout=5.0) for _ in range(3))
    try:
        # the witness hears a token once the router has it (its own session: a query from a session
        # that watches a token can be answered before that session has taken in what it heard)
        up = {"zenav/r1/alive/motor": threading.Event(), "zenav/r1/alive/sim": threading.Event()}
        gone = threading.Event()
        witness.watch_tokens("zenav/r1/alive/*", lambda key, alive: up[key].set() if alive else gone.set())
        first, twin = mine.token("zenav/r1/alive/motor"), mine.token("zenav/r1/alive/motor")
        theirs = other.token("zenav/r1/alive/sim")
        assert all(e.wait(WAIT) for e in up.values())
        for _ in range(5):
            assert mine.tokens("zenav/r1/alive/motor") == ["zenav/r1/alive/motor"]
        assert other.tokens("zenav/r1/alive/*") == ["zenav/r1/alive/motor", "zenav/r1/alive/sim"]
        assert mine.tokens("zenav/r1/alive/*") == ["zenav/r1/alive/motor", "zenav/r1/alive/sim"]
        first.undeclare()
        first.undeclare()  # once only: the twin still holds the key
        assert mine.tokens("zenav/r1/alive/motor") == ["zenav/r1/alive/motor"]
        twin.undeclare()
        assert gone.wait(WAIT)  # the router has let it go
        assert mine.tokens("zenav/r1/alive/motor") == []
        theirs.undeclare()
    finally:
        for bus in (mine, other, witness):
            bus.close()
