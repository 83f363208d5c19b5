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
