"""Safety, for real: the stack as processes, a frozen operator, a flood, bad inputs, duplicates, the field's edge.

The figures are printed (`pytest -s`); `zenav bench safety` prints them too.
"""

from __future__ import annotations

import subprocess
import sys

import pytest

from zenav.bench import safety
from zenav.common import codec
from zenav.common import messages as m
from zenav.robot import Robot

pytestmark = pytest.mark.system

FREEZE_STOP = 0.5  # [s] from SIGSTOP of the operator to zero cmd_vel and zero wheels
GAP_LIMIT = 1.5  # [s] longest pose gap a single bad input may cause (a blackout would be longer)
STEP_LIMIT = 0.05  # [m] a reset sim or a re-posed localizer jumps more than this between samples
LOG_LINE = 400  # [characters] longest log line allowed (clipped lines are 200 plus a note and a prefix)


@pytest.fixture(scope="module")
def rig(tmp_path_factory):
    r = safety.StackRig(tmp_path_factory.mktemp("safety"))
    yield r
    r.close()


@pytest.mark.parametrize("cli", [False, True], ids=["robot-library", "zenav-goto-wait"])
def test_frozen_operator_stops_the_robot(rig, cli):
    f = safety.frozen_operator(rig, cli)
    print(f"SIGSTOP -> zero cmd_vel {f.cmd_vel:.3f} s, zero wheels {f.wheels:.3f} s ({f.message})")
    assert f.message.startswith("aborted: lease lost"), f.message
    assert f.cmd_vel <= FREEZE_STOP and f.wheels <= FREEZE_STOP, f


def test_stop_overtakes_a_flood_of_goals(rig):
    fl = safety.stop_under_flood(rig)
    print(f"stop answered {fl.answered * 1000:.1f} ms, zero cmd_vel {fl.zero * 1000:.1f} ms, {fl.after}/{fl.goals} goals answered after it")
    # Whether goals still wait at the navigator when the stop arrives is a race this test cannot fix
    # (a fast navigator drains all 30 first): that the stop goes ahead of queued goals is asserted
    # deterministically in tests/services/test_navigator.py. Here: answered, and zero sent before the answer.
    assert fl.answered < safety.WAIT, fl
    assert fl.zero <= fl.answered + 0.1, fl  # the zero goes out as the stop is handled, before its answer travels back


def test_a_stop_voids_every_goal_that_reached_the_navigator_before_it(rig):
    b = safety.stop_after_a_burst(rig)
    print(f"stop answered {b.answered * 1000:.1f} ms; {b.queued}/{b.goals} goals answered after it, {b.voided} voided, {b.started} started")
    assert b.voided >= 1, b  # goals were still waiting at the navigator when the stop came (else this shows nothing)
    assert b.replies == b.goals and b.started == 0 and b.moving == 0, b  # each answered; none started after the stop; none drove


def test_bad_inputs_are_refused_without_a_pose_blackout(rig):
    gaps = safety.bad_inputs(rig)
    for g in gaps:
        print(f"pose gap {g.gap * 1000:.0f} ms around {g.what} ({g.counter} = {g.count})")
    for g in gaps[1:]:
        assert g.count >= 1, g
        assert g.gap < GAP_LIMIT, g


@pytest.mark.parametrize("query", [False, True], ids=["put", "query"])
def test_a_payload_over_the_routers_limit_never_reaches_the_service(rig, query):
    e = safety.oversize_at_the_edge(rig, query=query)
    print(f"{e.size} bytes ({'query' if query else 'put'}): oversize +{e.oversize}, pose gap {e.gap * 1000:.0f} ms")
    assert e.bad_input == 1 and e.oversize == 0, e  # the sample after it came; it did not
    assert e.gap < GAP_LIMIT, e


def test_no_log_line_carries_a_whole_payload(rig):
    reply = safety.echoed_field(rig)
    longest = max(len(line) for line in (rig.stack.log_dir / "r1-navigator.log").read_text().splitlines())
    print(f"error reply {reply} bytes, longest navigator log line {longest} characters")
    assert reply < LOG_LINE and longest < LOG_LINE


def test_wildcard_get_acts_on_nothing(rig):
    w = safety.wildcard_get(rig)
    print(w)
    assert w.goal_after == w.goal_before, w  # the goal runs on: not stopped, not replaced
    assert w.refused >= 3, w  # the navigator's goals and stop, the localizer's set_pose, the sim's reset
    assert w.jump < STEP_LIMIT and w.pose_jump < STEP_LIMIT, w


@pytest.mark.parametrize(("x", "why"), [(12_700.0, "<= 10000.0"), (5_000.0, "outside the field")])
def test_a_goal_kilometres_away_is_invalid(rig, x, why):
    replies = rig.bus.get(rig.client.key("nav/move_to_point"), payload=codec.encode({"x": x, "y": 0.0}), timeout=safety.WAIT)
    assert len(replies) == 1 and not replies[0][0], replies
    err = codec.decode(replies[0][1], m.ErrorReply)
    print(f"x = {x} m: {err.error}: {err.message}")
    assert err.error == "invalid_argument" and why in err.message, err


@pytest.mark.parametrize("services", [("navigator", "motor", "sim")])
def test_a_second_instance_is_refused(rig, services):
    procs = {
        s: subprocess.Popen(
            [sys.executable, "-m", f"zenav.services.{s}", "--connect", rig.endpoint],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
        for s in services
    }
    for s, p in procs.items():
        _, err = p.communicate(timeout=60)
        last = err.strip().splitlines()[-1]
        print(f"{s}: exit {p.returncode}: {last}")
        assert p.returncode == 3, err
        running = rig.stack.launcher.children[f"r1-{s}"].proc
        assert running is not None and running.poll() is None  # the first one runs on
        assert last.startswith(f"zenav-{s}: another {s} already runs for robot r1 (") and f"-{running.pid}-" in last, last


def test_a_second_instance_shows_in_diag(rig):
    token = rig.bus.token(rig.client.key("instance/navigator/intruder-1"))
    d = rig.client.latest("diag/navigator").wait(lambda d: "intruder-1" in d.message, timeout=safety.WAIT)
    print(d.status, d.message)
    assert d.status == "error" and "another navigator runs for robot r1" in d.message
    token.undeclare()
    rig.client.latest("diag/navigator").wait(lambda d: "intruder-1" not in d.message, timeout=safety.WAIT)


def test_leaving_the_field_stops_the_robot(rig):
    rig.ready()
    with Robot("r1", bus=rig.client.bus, lease=False) as bot:
        bot.turn_to_heading(0.0).wait(30)
        result = bot.move_straight(0.4).wait(30)
    print(result)
    assert result.result == "aborted" and "left the field" in result.message, result
    rig.truth.wait(lambda t: abs(t.v) < 0.01, timeout=safety.WAIT)
