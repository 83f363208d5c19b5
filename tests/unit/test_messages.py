"""The wire format: every message type is a plain msgpack map with string keys."""

import math

import msgpack
import msgspec
import pytest

from zenav.common import codec, keys
from zenav.common import messages as m
from zenav.common.geometry import Pose2, wrap_angle

ALL_TYPES = sorted(
    {*keys.TOPICS.values(), *(t for pair in keys.QUERIES.values() for t in pair), m.ErrorReply},
    key=lambda t: t.__name__,
)


def sample_value(t):
    """A valid value of a msgspec type (the smallest allowed collection)."""
    if isinstance(t, msgspec.inspect.FloatType):
        return 0.25
    if isinstance(t, msgspec.inspect.IntType):
        return 3
    if isinstance(t, msgspec.inspect.StrType):
        return "x"
    if isinstance(t, msgspec.inspect.BoolType):
        return True
    if isinstance(t, msgspec.inspect.BytesType):
        return b"\x00"
    if isinstance(t, msgspec.inspect.LiteralType):
        return t.values[0]
    if isinstance(t, (msgspec.inspect.VarTupleType, msgspec.inspect.ListType)):
        return [sample_value(t.item_type)] * max(t.min_length or 1, 1)
    if isinstance(t, msgspec.inspect.DictType):
        return {"k": sample_value(t.value_type)}
    if isinstance(t, msgspec.inspect.UnionType):
        return sample_value(next(x for x in t.types if not isinstance(x, msgspec.inspect.NoneType)))
    if isinstance(t, msgspec.inspect.StructType):
        return sample_dict(t.cls)
    if isinstance(t, msgspec.inspect.AnyType):
        return "any"
    raise AssertionError(f"no sample for {t}")


def sample_dict(cls):
    info = msgspec.inspect.type_info(cls)
    return {f.encode_name: sample_value(f.type) for f in info.fields}


@pytest.mark.parametrize("typ", ALL_TYPES, ids=lambda t: t.__name__)
def test_plain_msgpack_reads_every_message(typ):
    msg = msgspec.convert(sample_dict(typ), typ)
    plain = msgpack.unpackb(codec.encode(msg), raw=False)
    assert isinstance(plain, dict) and all(isinstance(k, str) for k in plain)
    assert set(plain) == {f.encode_name for f in msgspec.inspect.type_info(typ).fields}
    # and what a plain msgpack client sends decodes back to the same message
    assert codec.decode(msgpack.packb(plain), typ) == msg


@pytest.mark.parametrize("typ", [t for t in ALL_TYPES if issubclass(t, m.Topic)], ids=lambda t: t.__name__)
def test_topics_ignore_unknown_keys(typ):
    d = {**sample_dict(typ), "added_in_v2": [1, 2]}
    codec.decode(msgpack.packb(d), typ)


@pytest.mark.parametrize("typ", [t for t in ALL_TYPES if issubclass(t, m.Request)], ids=lambda t: t.__name__)
def test_requests_reject_unknown_keys_by_name(typ):
    d = {**sample_dict(typ), "tolerence": 0.1}
    with pytest.raises(codec.BadInput, match="tolerence") as e:
        codec.decode(msgpack.packb(d), typ)
    if any(f.name == "tolerance" for f in msgspec.structs.fields(typ)):
        assert str(e.value).endswith("unknown field `tolerence` (did you mean `tolerance`?)")


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf, 1e300, "1.0", None, [1.0]])
def test_bad_numbers_are_rejected_naming_the_field(bad):
    with pytest.raises(codec.BadInput, match=r"\$\.v"):
        codec.decode(msgpack.packb({"t": 1.0, "v": bad, "omega": 0.0}), m.CmdVel)


def test_a_nan_or_infinity_is_named_as_such_where_it_set_off_the_error():
    with pytest.raises(codec.BadInput) as e:
        codec.decode(msgpack.packb({"points": [[0.0, 0.0], [1.0, -math.inf]]}), m.FollowPath)
    assert str(e.value).endswith("at `$.points[1][1]` (`$.points[1][1]` is -inf: a number must be finite)")
    with pytest.raises(codec.BadInput) as e:
        codec.decode(msgpack.packb({"x": 1e9, "y": math.nan}), m.MoveToPoint)  # the error is x's: no word of y
    assert str(e.value) == "MoveToPoint: Expected `float` <= 10000.0 - at `$.x`"


def test_encoder_ticks_are_signed_32_bit():
    codec.decode(msgpack.packb({"t": 0.0, "left": -(2**31), "right": 2**31 - 1}), m.Encoders)
    with pytest.raises(codec.BadInput, match="left"):
        codec.decode(msgpack.packb({"t": 0.0, "left": 2**31, "right": 0}), m.Encoders)


def test_selector_parameters_convert_text():
    req = codec.from_params({"x": "1", "y": "-0.5", "wait": "true", "tolerance": "0.02"}, m.MoveToPoint)
    assert (req.x, req.y, req.wait, req.tolerance) == (1.0, -0.5, True, 0.02)
    path = codec.from_params({"points": "[[0,0],[1,0.5]]"}, m.FollowPath)
    assert path.points == [(0.0, 0.0), (1.0, 0.5)]
    with pytest.raises(codec.BadInput, match="x"):
        codec.from_params({"x": "one", "y": "0"}, m.MoveToPoint)


def test_every_contract_key_is_registered():
    assert set(keys.TOPICS) >= {
        "clock",
        "sim/truth",
        "sensors/encoders",
        "sensors/imu",
        "sensors/compass",
        "vps/pose",
        "odom",
        "pose",
        "cmd_vel",
        "motors/wheels",
        "nav/state",
        "localizer/fixes",
    } | {f"diag/{s}" for s in keys.SERVICES}
    assert set(keys.QUERIES) == {
        "nav/move_to_point",
        "nav/move_to_pose",
        "nav/turn_to_heading",
        "nav/swing_to_heading",
        "nav/turn_to_point",
        "nav/move_straight",
        "nav/follow_path",
        "nav/stop",
        "nav/status",
        "time/sync",
        "localizer/pose",
        "localizer/set_pose",
        "sim/reset",
    }


@pytest.mark.parametrize("robot", ["r1", "robot_2", "A-b-9"])
def test_robot_ids(robot):
    assert keys.key(robot, "odom") == f"zenav/{robot}/odom"
    assert keys.alive(robot, "sim") == f"zenav/{robot}/alive/sim"


@pytest.mark.parametrize("robot", ["", "r/1", "r*", "r 1", "zenav/**"])
def test_bad_robot_ids_are_refused(robot):
    with pytest.raises(ValueError, match="robot id"):
        keys.key(robot, "odom")


def test_wrap_angle_range():
    assert wrap_angle(math.pi) == pytest.approx(math.pi)
    assert wrap_angle(-math.pi) == pytest.approx(math.pi)
    assert wrap_angle(3 * math.pi / 2) == pytest.approx(-math.pi / 2)
    assert wrap_angle(-7.0) == pytest.approx(-7.0 + 2 * math.pi)


def test_pose2_compose_inverse_between():
    a, b = Pose2(1.0, 2.0, math.pi / 2), Pose2(0.5, 0.0, -math.pi / 4)
    ab = a.compose(b)
    assert ab == pytest.approx((1.0, 2.5, math.pi / 4))
    assert a.compose(a.inverse()) == pytest.approx((0.0, 0.0, 0.0), abs=1e-12)
    assert a.between(ab) == pytest.approx(tuple(b))


@pytest.mark.parametrize("payload", [b"\x81\xa2\xff\xfe\x01", b"\x91" * 100_000 + b"\x01"], ids=["not-utf8-key", "deep-nesting"])
def test_malformed_payloads_are_bad_input_not_crashes(payload):
    with pytest.raises(codec.BadInput):
        codec.decode(payload, m.CmdVel)
