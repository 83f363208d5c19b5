"""Zenoh encodings through a real router, seen by a plain zenoh session: msgpack samples, JSON replies on request."""

from __future__ import annotations

import json
import queue

import msgpack
import pytest
import zenoh

from zenav.common.bus import zenoh_config


@pytest.fixture
def session(make_stack, router):
    make_stack(["sim"])
    s = zenoh.open(zenoh_config("client", router))
    yield s
    s.close()


def get(session: zenoh.Session, selector: str) -> list[tuple[bool, str, bytes]]:
    """(ok, encoding, payload) of every reply."""
    out = []
    for rep in session.get(selector, timeout=10.0):
        sample = rep.ok if rep.ok is not None else rep.err
        assert sample is not None
        out.append((rep.ok is not None, str(sample.encoding), sample.payload.to_bytes()))
    return out


def test_a_plain_subscriber_sees_msgpack(session):
    samples: queue.Queue[zenoh.Sample] = queue.Queue()
    sub = session.declare_subscriber("zenav/r1/sim/truth", samples.put)
    try:
        sample = samples.get(timeout=20)
    finally:
        sub.undeclare()
    assert str(sample.encoding) == "application/msgpack"
    assert set(msgpack.unpackb(sample.payload.to_bytes())) >= {"t", "x", "y", "theta"}


def test_replies_are_msgpack_by_default(session):
    [(ok, encoding, data)] = get(session, "zenav/r1/sim/reset?x=0.5")
    assert ok and encoding == "application/msgpack" and msgpack.unpackb(data)["x"] == 0.5


def test_format_json_as_a_rest_client_asks(session):
    [(ok, encoding, data)] = get(session, "zenav/r1/sim/reset?x=0.25;y=-1;_format=json;_raw")  # as the REST plugin passes it on
    rep = json.loads(data.decode())
    assert ok and encoding == "application/json" and (rep["x"], rep["y"]) == (0.25, -1.0)
    [(ok, encoding, data)] = get(session, "zenav/r1/sim/reset?x=abc;_format=json")
    err = json.loads(data.decode())
    assert not ok and encoding == "application/json" and err["error"] == "invalid_argument" and "$.x" in err["message"]
