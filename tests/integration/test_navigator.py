"""The navigator's contract through a real router: a zenoh+msgpack client, the CLI, the path trial."""

from __future__ import annotations

import math
import subprocess
import sys

import pytest

from tests.support.rawclient import RawClient

RTF = 1.0  # realtime: six services share one process (one GIL) here
# One process's GIL can stall the pose for half a second on a busy 2-core machine; these
# tests are about the query API and the path, so a pose may be older before a goal aborts.
# The final re-check judges the fused pose, which late VPS fixes move by a centimetre or two:
# a 3 cm default tolerance keeps these API tests about the API (the path trial checks the truth).
NAV = {"stale_after": 2.0, "tolerance": 0.03}
TRIAL = {"stale_after": 2.0}  # the path trial at the default tolerance
PATH = [[1.0, 0.0], [1.0, 1.0]]  # the path trial from (0, 0, 0)


@pytest.fixture
def raw(make_stack, router):
    make_stack(["sim", "motor", "odometry", "vps", "localizer", "navigator"], sim={"rtf": RTF}, navigator=NAV)
    c = RawClient(router)
    c.follow("sim/truth")
    c.follow("pose")
    c.wait(lambda latest: "pose" in latest, timeout=30)
    c.wait_nav_ready()
    yield c
    c.close()


def test_every_nav_query_from_a_zenoh_and_msgpack_client(raw):
    ok, st = raw.query("nav/status")
    assert ok and st["state"] == "STOPPED" and st["pose"] is not None
    ok, err = raw.query("nav/move_to_point", {"x": 1.0, "tolerence": 0.1})
    assert not ok and err["error"] == "invalid_argument" and "tolerence" in err["message"]
    ok, err = raw.query("nav/move_to_point", params="x=abc;y=0")
    assert not ok and err["error"] == "invalid_argument" and "$.x" in err["message"]
    for suffix, request, params in [
        ("nav/move_to_point", None, "x=0.3;y=0.1;wait=true"),
        ("nav/turn_to_heading", {"heading": 1.0, "wait": True}, ""),
        ("nav/turn_to_point", {"x": 0.0, "y": 0.0, "wait": True}, ""),
        ("nav/move_straight", {"speed": 0.1, "distance": 0.1, "wait": True}, ""),
        ("nav/follow_path", None, "points=[[0.2,0.2],[0.0,0.2]];wait=true"),
    ]:
        ok, rep = raw.query(suffix, request, params=params, timeout=60)
        assert ok and rep["result"] == "succeeded", (suffix, rep)
    ok, rep = raw.query("nav/move_straight", {"speed": -5.0})
    assert ok and rep["state"] == "MOVING_STRAIGHT" and rep["speed"] == pytest.approx(-0.3)
    ok, rep = raw.query("nav/stop")
    assert ok and rep == {"state": "STOPPED"}


def test_lease_lost_stops_the_robot(raw):
    token = raw.session.liveliness().declare_token("zenav/r1/lease/test")
    ok, rep = raw.query("nav/move_to_point", {"x": 2.0, "y": 0.0, "lease": "zenav/r1/lease/test"})
    assert ok and rep["state"] == "MOVING_TO_POINT"
    raw.wait(lambda latest: abs(latest["sim/truth"]["v"]) > 0.1, timeout=10)
    token.undeclare()
    raw.wait(lambda latest: abs(latest["sim/truth"]["v"]) < 0.01, timeout=5)
    ok, st = raw.query("nav/status")
    assert st["result"] == "aborted"
    ok, err = raw.query("nav/move_to_point", {"x": 0.0, "y": 0.0, "lease": "zenav/r1/lease/nobody"})
    assert not ok and err["error"] == "unavailable"


def test_cli_goto_wait_and_exit_codes(raw, router):
    def zenav(*args):
        cmd = [sys.executable, "-m", "zenav", *args, "--connect", router]
        return subprocess.run(cmd, capture_output=True, text=True, timeout=120)

    done = zenav("goto", "0.3", "0", "--wait")
    assert done.returncode == 0 and "succeeded" in done.stdout, done
    assert zenav("turn", "90", "--deg", "--wait").returncode == 0
    assert zenav("goto", "1", "0", "--tolerance", "-1").returncode == 2
    assert zenav("goto", "1", "0", "--robot", "nobody", "--timeout", "1").returncode == 3


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_path_trial(make_stack, router, seed):
    """The path trial in the `default` scenario; its real robot (docs/provenance.md): 11.4 cm mean, 3.9 cm sd."""
    make_stack(["sim", "motor", "odometry", "vps", "localizer", "navigator"], sim={"rtf": RTF}, deployment={"seed": seed}, navigator=TRIAL)
    c = RawClient(router)
    try:
        c.follow("sim/truth")
        c.follow("pose")
        c.wait(lambda latest: "pose" in latest, timeout=30)
        c.wait_nav_ready()
        ok, rep = c.query("nav/follow_path", {"points": PATH, "wait": True}, timeout=120)
        assert ok and rep["result"] == "succeeded", rep
        truth = c.wait(lambda latest: abs(latest["sim/truth"]["v"]) < 0.005, timeout=5)["sim/truth"]
        error = math.hypot(truth["x"] - 1.0, truth["y"] - 1.0)
        assert error < 0.05  # targets: 1.5 cm mean, 3 cm max over 10 seeds; measured 0.58 / 1.40 cm
    finally:
        c.close()
