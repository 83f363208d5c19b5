"""What `zenav topics | echo | hz | query` make of keys, payloads and arrival times."""

import json
import math

import msgspec
import pytest

from zenav.cli import wire
from zenav.cli.main import EXIT_USAGE, main
from zenav.common import codec
from zenav.common import messages as m
from zenav.stack.inprocess import free_port


@pytest.mark.parametrize(
    "key, full",
    [
        ("pose", "zenav/r1/pose"),
        ("diag/*", "zenav/r1/diag/*"),
        ("**", "zenav/r1/**"),
        ("zenav/r2/odom", "zenav/r2/odom"),
        ("zenav/field/camera/frame", "zenav/field/camera/frame"),
        ("camera/frame", "zenav/field/camera/frame"),  # a field topic: the field's, whichever robot
        ("sim/body", "zenav/field/sim/body"),
        ("@/*/router", "@/*/router"),
    ],
)
def test_keys_are_relative_to_the_robot_unless_absolute(key, full):
    assert wire.resolve("r1", key) == full


@pytest.mark.parametrize("key", ["a//b", "pose?x=1", "", "diag/#"])
def test_a_bad_key_says_what_a_key_is(key):
    with pytest.raises(ValueError, match="is not a key expression"):
        wire.resolve("r1", key)


def test_contract_types_of_keys():
    assert wire.topic_type("zenav/r1/pose") is m.Pose and wire.topic_type("zenav/r7/diag/motor") is m.Diag
    assert wire.topic_type("zenav/field/camera/frame") is m.CameraFrame
    assert wire.topic_type("zenav/r1/nosuch") is None and wire.topic_type("other/r1/pose") is None
    assert wire.query_types("zenav/r1/nav/status") == (m.Empty, m.StatusReply)
    assert wire.query_types("zenav/r1/pose") is None and wire.query_types("zenav/r1/nav/*") is None


POSE = m.Pose(t=1.5, x=0.25, y=-1.0, theta=0.5, v=0.1, omega=0.0)


def test_a_key_that_names_no_topic_is_noted_with_the_nearest_name():
    assert wire.unknown_topic("zenav/r1/odon") == "odon is no topic of the contract (did you mean odom?); listening anyway"
    assert wire.unknown_topic("zenav/r2/sensor/imu").startswith("sensor/imu is no topic of the contract (did you mean sensors/imu?)")
    assert "(did you mean camera/frame?)" in wire.unknown_topic("zenav/field/camera/frames")
    assert wire.unknown_topic("zenav/r1/xyzzy") == "xyzzy is no topic of the contract; listening anyway"
    assert wire.unknown_topic("zenav/r1/alive/sim").startswith("alive/sim is a liveliness token, which sends no messages")
    assert wire.unknown_topic("zenav/r1/nav/status").startswith("nav/status is a query, which sends no messages: `zenav query nav/status`")
    for key in ("zenav/r1/odom", "zenav/r1/diag/motor", "zenav/r1/diag/*", "zenav/r1/**", "zenav/field/camera/frame", "other/k", "@/x"):
        assert wire.unknown_topic(key) is None, key


def test_payloads_decode_as_their_type_else_as_what_they_are():
    kind, value = wire.decode(codec.encode(POSE), m.Pose)
    assert kind == "Pose" and value["x"] == 0.25 and value["theta"] == 0.5
    assert wire.decode(codec.encode({"a": [1, 2]}), m.Pose) == ("msgpack", {"a": [1, 2]})  # not a Pose: shown as it is
    assert wire.decode(b'{"a": 1}') == ("json", {"a": 1})
    assert wire.decode(b"hello") == ("text", "hello")
    assert wire.decode(b"\xff\xfe\x00") == ("bytes", 3)


def test_a_json_line_per_sample():
    line = wire.json_line("zenav/r1/pose", codec.encode(POSE), m.Pose)
    assert "\n" not in line
    obj = json.loads(line)
    assert obj["key"] == "zenav/r1/pose" and obj["type"] == "Pose" and obj["msg"]["y"] == -1.0
    nan = json.loads(wire.json_line("k", codec.encode({"v": math.nan, "b": b"\x00\x01"})))
    assert nan["msg"] == {"v": None, "b": "AAE="}  # valid JSON: NaN as null, bytes as base64


def test_error_replies():
    data = codec.encode(m.ErrorReply(error="invalid_argument", message="x: expected a number"))
    assert wire.error_reply(data) == ("invalid_argument", "x: expected a number")
    assert wire.error_reply(b"Timeout") == ("unavailable", "Timeout")
    assert wire.error_reply(b"boom") == ("internal", "boom")


def test_params_are_json_where_they_parse():
    got = wire.parse_params(["x=1", "y=-0.5", "name=r1", "flag=true", 'quoted="7"', "points=[[0,0],[1,0]]", "empty=", "eq=a=b"])
    assert got == {"x": 1, "y": -0.5, "name": "r1", "flag": True, "quoted": "7", "points": [[0, 0], [1, 0]], "empty": "", "eq": "a=b"}
    assert msgspec.convert(wire.parse_params(["x=1", "y=2"]), m.MoveToPoint).x == 1.0
    for bad in ("x", "=1"):
        with pytest.raises(ValueError, match="is not KEY=VALUE"):
            wire.parse_params([bad])


def test_rate_of_arrivals():
    r = wire.rate([0.0, 0.1, 0.2, 0.3, 0.5])
    assert r.count == 5 and r.hz == pytest.approx(8.0) and r.min == pytest.approx(0.1) and r.max == pytest.approx(0.2)
    assert r.std == pytest.approx(math.sqrt((3 * 0.025**2 + 0.075**2) / 4))
    assert wire.rate([]) == wire.Rate(0, None, None, None, None) and wire.rate([3.0]).hz is None
    assert wire.rate([1.0, 1.0]).hz == math.inf  # two at once: no division by zero


def test_hz_line_reads_like_ros2():
    line = wire.hz_line("zenav/r1/odom", wire.rate([0.0, 0.01, 0.02, 0.03]))
    assert line.startswith("zenav/r1/odom: average rate 100.000 Hz") and "min 0.0100 s" in line and "window 4" in line
    assert wire.hz_line("k", wire.rate([1.0])) == "k: 1 message, no rate yet"


def test_topics_table():
    seen = [
        wire.Seen("zenav/r1/pose", "Pose", wire.rate([0.0, 0.02, 0.04]), 60.0),
        wire.Seen("zenav/r1/diag/sim", "Diag", wire.rate([0.5]), 200.0),
    ]
    text = wire.topics_table(seen, ["zenav/r1/alive/sim"], 2.0)
    lines = text.splitlines()
    assert lines[0] == "2 keys with publishers in 2 s" and lines[1].split() == ["KEY", "TYPE", "RATE", "MSGS", "BYTES"]
    assert lines[2].split() == ["zenav/r1/diag/sim", "Diag", "-", "1", "200"]  # sorted by key
    assert lines[3].split() == ["zenav/r1/pose", "Pose", "50.0", "Hz", "3", "60"]
    assert lines[4:] == ["1 liveliness token", "  zenav/r1/alive/sim"]
    assert wire.topics_table([], [], 0.5).splitlines() == ["0 keys with publishers in 0.5 s", "0 liveliness tokens"]


@pytest.mark.parametrize(
    "argv, words",
    [
        (["echo", "a//b"], "zenav echo: 'a//b' is not a key expression"),
        (["hz", "pose?x=1"], "zenav hz: 'pose?x=1' is not a key expression"),
        (["query", "nav/status", "verbose"], "zenav query: 'verbose' is not KEY=VALUE"),
        (["query", "localizer/set_pose", "x=abc"], "zenav query: SetPose: Expected `float | null`, got `str` - at `$.x`"),
        (["topics", "--robot", "r 1"], "zenav topics: --robot: robot id 'r 1' must match"),
    ],
)
def test_bad_arguments_fail_before_connecting(argv, words, capsys):
    assert main([*argv, "--connect", f"tcp/127.0.0.1:{free_port()}"]) == EXIT_USAGE  # a connection attempt: exit 3
    err = capsys.readouterr().err
    assert err.startswith(words) and err.count("\n") == 1


@pytest.mark.parametrize("argv", [["echo", "pose", "--count", "0"], ["hz", "pose", "--window", "-1"], ["topics", "--window", "nan"]])
def test_bad_bounds_are_usage_errors(argv):
    with pytest.raises(SystemExit) as e:
        main(argv)
    assert e.value.code == EXIT_USAGE
