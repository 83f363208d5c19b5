"""Reply formats on the in-memory bus: msgpack by default, JSON text when a query asks `_format=json`."""

import json

import pytest

from tests.support.echo import Echo
from zenav.common import codec
from zenav.common import messages as m
from zenav.common.bus import JSON, MSGPACK, MemoryBus
from zenav.common.clock import ManualClock
from zenav.common.config import Settings
from zenav.common.runtime import reply_ok


@pytest.fixture
def svc():
    bus = MemoryBus()
    s = Echo(Settings.load(None), bus, ManualClock())
    s.start()
    yield s, bus
    s.close()


def ask(s, bus, payload=b"", **params):
    q = bus.query("zenav/r1/localizer/set_pose", payload, params)
    s.drain()
    return q


def test_msgpack_by_default(svc):
    q = ask(*svc, x="1.5", y="2")
    assert q.replies == [(True, codec.encode(m.PoseStamped(t=0.0, x=1.5, y=2.0, theta=0.0)))]
    assert q.encodings == [MSGPACK] and q.finished


def test_format_json_replies_json_text_and_is_not_a_request_field(svc):
    q = ask(*svc, x="1.5", y="2", _format="json")
    [(ok, data)] = q.replies
    assert ok and q.encodings == [JSON]
    assert json.loads(data) == {"t": 0.0, "x": 1.5, "y": 2.0, "theta": 0.0}


def test_zenoh_s_own_parameters_are_not_request_fields(svc):
    q = ask(*svc, x="2", _format="json", _raw="", _time="[now(-1s)..]")  # as zenoh's REST plugin passes them on
    assert q.replies[0][0] and json.loads(q.replies[0][1])["x"] == 2.0


def test_format_json_with_a_msgpack_payload(svc):
    q = ask(*svc, codec.encode({"x": 2.0}), _format="json")
    assert q.encodings == [JSON] and json.loads(q.replies[0][1])["x"] == 2.0


def test_format_msgpack_asked_explicitly(svc):
    q = ask(*svc, x="1", _format="msgpack")
    assert q.encodings == [MSGPACK] and codec.decode(q.replies[0][1], m.PoseStamped).x == 1.0


@pytest.mark.parametrize(
    ("params", "code", "words"),
    [
        ({"x": "abc"}, "invalid_argument", "$.x"),  # bad request field
        ({"x": "1", "tolerence": "2"}, "invalid_argument", "tolerence"),  # unknown fields stay forbidden
        ({"x": "13"}, "unavailable", "unlucky"),  # the handler's QueryError
    ],
)
def test_error_replies_in_json(svc, params, code, words):
    q = ask(*svc, **params, _format="json")
    [(ok, data)] = q.replies
    err = json.loads(data)
    assert not ok and q.encodings == [JSON] and err["error"] == code and words in err["message"]


def test_unknown_format_is_refused_in_msgpack(svc):
    s, bus = svc
    q = ask(s, bus, x="1", _format="xml")
    [(ok, data)] = q.replies
    err = codec.decode(data, m.ErrorReply)
    assert not ok and q.encodings == [MSGPACK] and err.error == "invalid_argument" and "_format=xml" in err.message
    assert s.counters.values["bad_input"] == 1


def test_a_held_query_is_answered_later_in_its_format(svc):
    s, bus = svc
    q = ask(s, bus, x="7", _format="json")
    assert q.replies == [] and s.held is q
    reply_ok(q, m.PoseStamped(t=1.0, x=7.0, y=0.0, theta=0.0))
    assert q.encodings == [JSON] and json.loads(q.replies[0][1])["x"] == 7.0


def test_oversize_parameters_are_refused_without_reading_them(svc):
    s, bus = svc
    q = ask(s, bus, x="1" * (s.limits.max_params + 1), _format="json")
    [(ok, data)] = q.replies
    assert not ok and q.encodings == [MSGPACK] and codec.decode(data, m.ErrorReply).error == "invalid_argument"
    assert s.counters.values["oversize"] == 1
