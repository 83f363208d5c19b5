"""A second simulated robot joining a router where another robot's sim renders the field's one camera."""

from __future__ import annotations

import zenoh

from zenav.cli import up
from zenav.cli.main import main
from zenav.common.bus import zenoh_config


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
