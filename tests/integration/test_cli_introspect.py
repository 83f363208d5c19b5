"""`zenav topics | echo | hz | query` against a real router and stack, and every client command with no router."""

from __future__ import annotations

import json
import time

import pytest

from zenav.cli import introspect, session
from zenav.cli.main import EXIT_FAILED, EXIT_OK, EXIT_UNAVAILABLE, EXIT_USAGE, main
from zenav.stack.inprocess import free_port

NAV = {"stale_after": 2.0}


@pytest.fixture
def stack(make_stack):
    """The sim (clock, truth, sensors at 100 Hz) and the navigator (queries), on `router`."""
    return make_stack(["sim", "navigator"], navigator=NAV)


def zenav(capsys, *argv):
    """Run `zenav argv...` in this process: (exit code, stdout lines, stderr)."""
    code = main(list(argv))
    out = capsys.readouterr()
    return code, out.out.splitlines(), out.err


def test_topics_lists_keys_types_rates_and_tokens(stack, router, capsys):
    code, out, err = zenav(capsys, "topics", "--connect", router, "--window", "1.5")
    assert code == EXIT_OK, err
    rows = {line.split()[0]: line.split() for line in out[2:] if line.startswith("zenav/r1/")}
    assert rows["zenav/r1/clock"][1] == "Clock" and rows["zenav/r1/sensors/encoders"][1] == "Encoders"
    encoders, clock = float(rows["zenav/r1/sensors/encoders"][2]), float(rows["zenav/r1/clock"][2])
    assert 20.0 < encoders < 200.0 and rows["zenav/r1/clock"][3] == "Hz"
    assert 5.0 < clock < encoders  # [sim] clock_rate_hz 20 against the 100 Hz sensors
    tokens = [line.strip() for line in out if line.startswith("  ")]
    assert {"zenav/r1/alive/sim", "zenav/r1/alive/navigator"} <= set(tokens)
    field = [line.split() for line in out if line.startswith("zenav/field/")]
    assert [row[:2] for row in field] == [["zenav/field/sim/body", "Body"]]  # the field's keys too, every robot's


def test_echo_prints_json_lines_with_wildcards_and_absolute_keys(stack, router, capsys):
    code, out, err = zenav(capsys, "echo", "clock", "--connect", router, "--count", "3", "--timeout", "10")
    assert code == EXIT_OK, err
    msgs = [json.loads(line) for line in out]
    assert len(msgs) == 3 and all(m["key"] == "zenav/r1/clock" and m["type"] == "Clock" for m in msgs)
    assert msgs[0]["msg"]["t"] < msgs[2]["msg"]["t"]
    code, out, err = zenav(capsys, "echo", "diag/*", "--connect", router, "--once", "--timeout", "10")
    [diag] = [json.loads(line) for line in out]
    assert code == EXIT_OK and diag["key"].startswith("zenav/r1/diag/") and diag["type"] == "Diag" and "counters" in diag["msg"]
    code, out, err = zenav(capsys, "echo", "zenav/r1/sim/truth", "--connect", router, "--once", "--timeout", "10")
    assert code == EXIT_OK and json.loads(out[0])["type"] == "Truth"


def test_echo_of_a_silent_key_gives_up(stack, router, capsys):
    code, out, err = zenav(capsys, "echo", "nosuch/topic", "--connect", router, "--timeout", "0.3")
    said = [
        "zenav echo: nosuch/topic is no topic of the contract; listening anyway",
        "zenav echo: no message on zenav/r1/nosuch/topic in 0.3 s",
    ]
    assert code == EXIT_FAILED and out == [] and err.splitlines() == said


def test_echo_and_hz_name_the_topic_a_typo_meant_and_say_they_still_listen(stack, router, capsys, monkeypatch):
    monkeypatch.setattr(introspect, "QUIET_NOTE", 0.1)
    code, out, err = zenav(capsys, "echo", "odon", "--connect", router, "--timeout", "1")
    said = [
        "zenav echo: odon is no topic of the contract (did you mean odom?); listening anyway",
        "zenav echo: nothing on zenav/r1/odon yet; still listening (zenav topics lists what is published)",
        "zenav echo: no message on zenav/r1/odon in 1 s",
    ]
    assert code == EXIT_FAILED and out == [] and err.splitlines() == said
    code, out, err = zenav(capsys, "hz", "odom", "--connect", router, "--window", "1")  # a topic, not published here: no odometry
    said = [
        "zenav hz: nothing on zenav/r1/odom yet; still listening (zenav topics lists what is published)",
        "zenav hz: no message on zenav/r1/odom in 1.0 s",
    ]
    assert code == EXIT_FAILED and err.splitlines() == said
    code, out, err = zenav(capsys, "echo", "clock", "--connect", router, "--once", "--timeout", "10")
    assert code == EXIT_OK and err == ""


def test_hz_measures_the_rate(stack, router, capsys):
    t0 = time.monotonic()
    code, out, err = zenav(capsys, "hz", "sensors/encoders", "--connect", router, "--count", "150", "--window", "20")
    assert code == EXIT_OK, err
    last = out[-1]
    assert last.startswith("zenav/r1/sensors/encoders: average rate ") and "window 150" in last
    rate = float(last.split("average rate ")[1].split()[0])
    assert 20.0 < rate < 200.0  # 100 Hz of sim time, on a shared host
    assert time.monotonic() - t0 < 20.0
    code, out, err = zenav(capsys, "hz", "nosuch/topic", "--connect", router, "--window", "0.3")
    assert code == EXIT_FAILED and "no message on zenav/r1/nosuch/topic" in err


def test_query_prints_the_decoded_reply(stack, router, capsys):
    code, out, err = zenav(capsys, "query", "nav/status", "--connect", router)
    assert code == EXIT_OK, err
    [reply] = [json.loads(line) for line in out]
    assert reply["key"] == "zenav/r1/nav/status" and reply["type"] == "StatusReply" and reply["msg"]["state"] == "STOPPED"


def test_query_error_replies_and_no_reply(stack, router, capsys):
    code, out, err = zenav(capsys, "query", "nav/move_to_point", "x=99", "y=0", "speed=-1", "--connect", router)
    assert code == EXIT_USAGE and out == [] and "speed" in err  # refused before sending
    code, out, err = zenav(capsys, "query", "nav/move_to_point", "x=0.1", "y=0", "--connect", router)
    assert code == EXIT_UNAVAILABLE and err.startswith("zenav query: zenav/r1/nav/move_to_point: unavailable: ")  # no pose yet
    code, out, err = zenav(capsys, "query", "nosuch/service", "--connect", router, "--timeout", "0.5")
    assert code == EXIT_UNAVAILABLE and "no reply from zenav/r1/nosuch/service" in err


CLIENT_COMMANDS = [
    ["goto", "1", "0"],
    ["turn", "1"],
    ["face", "1", "0"],
    ["straight", "0.1"],
    ["path", "1,0"],
    ["stop"],
    ["set-pose", "0", "0"],
    ["status"],
    ["topics"],
    ["echo", "pose"],
    ["hz", "pose"],
    ["query", "nav/status"],
]


@pytest.mark.parametrize("argv", CLIENT_COMMANDS, ids=lambda a: a[0])
def test_no_router_fails_fast_in_one_line(argv, capsys, monkeypatch):
    monkeypatch.setattr(session, "CONNECT_TIMEOUT", 0.5)
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    t0 = time.monotonic()
    code, out, err = zenav(capsys, *argv, "--connect", endpoint)
    assert code == EXIT_UNAVAILABLE and out == [] and time.monotonic() - t0 < 5.0
    assert err.startswith(f"zenav {argv[0]}: no Zenoh router at {endpoint} (") and err.count("\n") == 1
    assert ".rs:" not in err


@pytest.mark.parametrize("argv", CLIENT_COMMANDS, ids=lambda a: a[0])
def test_a_bad_robot_id_fails_before_connecting(argv, capsys):
    code, out, err = zenav(capsys, *argv, "--robot", "a/b", "--connect", f"tcp/127.0.0.1:{free_port()}")  # connecting: exit 3
    assert code == EXIT_USAGE and err.startswith(f"zenav {argv[0]}: --robot: robot id 'a/b' must match ") and err.count("\n") == 1


def test_stop_and_status_on_a_partial_stack(stack, router, capsys):
    code, out, err = zenav(capsys, "stop", "--connect", router)
    assert code == EXIT_OK and out == ["stopped (STOPPED)"], err
    code, out, err = zenav(capsys, "status", "--connect", router, "--timeout", "1.5")
    assert code == EXIT_UNAVAILABLE and out[0] == "robot r1: 2/6 services alive" and err.startswith("missing: ")
    assert any(line.startswith("nav    STOPPED") for line in out)
    header, sim = out[1].split(), next(line.split() for line in out if line.startswith("sim "))
    assert header[7] == "cpu" and sim[7].endswith("%") and float(sim[7][:-1]) > 0.0  # the sim's process's, of one core
    assert header[5:7] == ["bad", "dropped"] and sim[5].isdigit() and sim[6].isdigit()


def test_status_of_named_services_is_their_liveliness(stack, router, capsys):
    code, out, err = zenav(capsys, "status", "--connect", router, "--service", "sim", "--service", "navigator")
    assert code == EXIT_OK and out == ["robot r1: sim alive, navigator alive"], err
    code, out, err = zenav(capsys, "status", "--connect", router, "--service", "sim", "--service", "motor")
    assert code == EXIT_UNAVAILABLE and out == ["robot r1: sim alive, motor not alive"], err
