"""Two simulated robots on one router: the field's one camera, and their bodies, which keep out of each other."""

from __future__ import annotations

import math

import zenoh

from zenav.cli import up
from zenav.cli.main import main
from zenav.common import messages as m
from zenav.common.bus import zenoh_config
from zenav.common.client import Client


def test_a_second_robot_whose_sim_would_render_a_second_camera_is_refused(make_stack, router, client, capsys):
    make_stack(["sim"], sim={"camera": True})  # r1's sim: the field's camera frames
    client.wait_alive(["sim"], timeout=20.0)
    session = zenoh.open(zenoh_config("client", connect=router))
    try:
        assert up.frames_elsewhere(session, "r2")
        assert not up.frames_elsewhere(session, "r1")  # its own sim: a second instance is refused by its own check
    finally:
        session.close()
    assert main(["up", "--robot", "r2", "--connect", router]) == 2
    err = capsys.readouterr().err
    assert "frames already come on zenav/field/camera/frame" in err and "--set sim.camera=false --set vps.source=synthetic" in err


def test_a_robot_without_a_camera_on_the_field_is_not_held_up(make_stack, router, client):
    make_stack(["sim"], sim={"camera": False})
    client.wait_alive(["sim"], timeout=20.0)
    session = zenoh.open(zenoh_config("client", connect=router))
    try:
        assert not up.frames_elsewhere(session, "r2", wait=0.5)
    finally:
        session.close()


def test_a_simulated_robot_that_drives_into_another_stops_at_its_body(make_stack, router, client):
    make_stack(["sim"], sim={"camera": False})  # r1 at the origin; each a body of [sim] body_radius, 0.1 m
    make_stack(["sim"], deployment={"robot": "r2"}, sim={"camera": False, "x0": 0.5, "rtf": 2.0})  # its clock runs ahead of r1's
    client.wait_alive(["sim"], timeout=20.0)
    with Client("r2", router) as r2:
        r2.wait_alive(["sim"], timeout=20.0)
        other = r2.latest("sim/truth")
        truth = client.latest("sim/truth")
        t0 = t = truth.wait(timeout=20.0).t
        while t < t0 + 4.0:  # 40 commands, 0.1 s of sim time apart: at 0.17 m/s, 0.67 m on an empty field
            client.publish("motors/wheels", m.Wheels(t=t, left=5.0, right=5.0))
            t = truth.wait(lambda msg, t=t: msg.t >= t + 0.1, timeout=10.0).t
        client.publish("motors/wheels", m.Wheels(t=t, left=0.0, right=0.0))
        end, there = truth.msg, other.wait(timeout=10.0)
    assert math.hypot(there.x - end.x, there.y - end.y) >= 0.2 - 0.02  # two radii: no deeper than its 20 Hz reports go stale
    assert end.x > 0.25 and there.x == 0.5  # it drove up to r2, and did not push it
    diag = client.latest("diag/sim").wait(lambda d: d.counters.get("contacts", 0) >= 1, timeout=10.0)
    assert diag.counters["contacts"] == 1


STACK = ["sim", "motor", "odometry", "vps", "localizer", "navigator"]
NAV = {"stale_after": 2.0, "tolerance": 0.03}  # six services per robot share one process: a pose may come late


def test_two_robots_swapping_places_both_arrive_and_their_sims_count_no_contact(make_stack, router, client):
    """Each navigator drives round the other robot's body (zenav/field/robots): both goals reached, no contact."""
    make_stack(STACK, sim={"camera": False, "x0": 0.0, "y0": 0.5}, navigator=NAV)
    make_stack(STACK, deployment={"robot": "r2"}, sim={"camera": False, "x0": 1.2, "y0": 0.5, "theta0": math.pi}, navigator=NAV)
    with Client("r2", router) as r2:
        bots = {"r1": client, "r2": r2}
        for c in bots.values():
            c.wait_alive(STACK, timeout=30.0)
            pose = c.latest("pose")
            for _ in range(300):  # bounded: a pose 0.1 s apart each, 30 s of stack time at most
                if not c.query("nav/status").not_ready:
                    break
                t = pose.wait(timeout=10.0).t
                pose.wait(lambda p, t=t: p.t >= t + 0.1, timeout=10.0)
        states = {name: c.latest("nav/state") for name, c in bots.items()}
        ids = {
            "r1": client.query("nav/move_to_point", {"x": 1.2, "y": 0.5}).goal_id,
            "r2": r2.query("nav/move_to_point", {"x": 0.0, "y": 0.5}).goal_id,
        }
        ends = {n: s.wait(lambda st, n=n: st.goal_id == ids[n] and st.result is not None, timeout=120.0) for n, s in states.items()}
        assert {n: (e.result, e.message) for n, e in ends.items()} == {"r1": ("succeeded", "arrived"), "r2": ("succeeded", "arrived")}
        for c in bots.values():
            diag = c.latest("diag/sim").wait(timeout=10.0)
            assert diag.counters.get("contacts", 0) == 0
        truth = {n: c.latest("sim/truth").wait(timeout=10.0) for n, c in bots.items()}
    assert math.hypot(truth["r1"].x - 1.2, truth["r1"].y - 0.5) < 0.05 and math.hypot(truth["r2"].x, truth["r2"].y - 0.5) < 0.05
