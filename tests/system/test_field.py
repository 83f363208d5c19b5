"""The field's obstacles, for real: `zenav up` as processes on a field with a box; the sim counts contacts."""

from __future__ import annotations

import math

import pytest

from tests.support.procs import Stack
from zenav.common import messages as m
from zenav.common.client import InvalidArgument
from zenav.common.field import polygon_shape

pytestmark = pytest.mark.system

BOX = [[0.55, -0.1], [0.75, -0.1], [0.75, 0.1], [0.55, 0.1]]
RADIUS = 0.1  # [robot] radius and [sim] body_radius, the defaults
SERVICES = ["sim", "odometry", "vps", "localizer", "navigator", "motor"]


@pytest.fixture
def stack(tmp_path):
    config = tmp_path / "zenav.toml"
    config.write_text(f'[field]\nobstacles = [{{ name = "box", polygon = {BOX} }}]\n')
    s = Stack(tmp_path, extra=["--config", str(config)])
    s.client.wait_alive(SERVICES, timeout=60.0)
    s.client.latest("pose").wait(timeout=30.0)
    yield s
    s.close()


def test_a_raw_cmd_vel_driven_at_the_box_stops_before_contact(stack):
    c, box = stack.client, polygon_shape("box", BOX)
    t0 = t = stack.truth.wait(timeout=20.0).t
    while t < t0 + 5.0:  # 50 commands 0.1 s of sim time apart at 0.2 m/s: 1 m, through the box, without the guard
        c.publish("cmd_vel", m.CmdVel(t=0.0, v=0.2, omega=0.0))
        t = stack.truth.wait(lambda msg, t=t: msg.t >= t + 0.1, timeout=10.0).t
    end = stack.truth.msg
    gap = box.clearance(end.x, end.y) - RADIUS
    assert 0.0 < gap < 0.05, (end.x, end.y)  # stopped short of the box, close to it (the guard's gap and the pose's doubt)
    sim = stack.diag("sim").wait(lambda d: d.t >= t, timeout=10.0)
    assert sim.counters["contacts"] == 0
    motor = stack.diag("motor").wait(lambda d: d.counters.get("guard_stopped", 0) > 0, timeout=10.0)
    assert motor.counters["guard_slowed"] > 0
    state = stack.nav.wait(lambda s: s.guard.startswith("obstacles[0] 'box'"), timeout=10.0)
    assert state.guard.endswith("ahead")


def test_a_goal_behind_the_box_is_reached_round_it_and_one_inside_refused(stack):
    c, box = stack.client, polygon_shape("box", BOX)
    least = [math.inf]
    c.subscribe("sim/truth", lambda msg: least.__setitem__(0, min(least[0], box.clearance(msg.x, msg.y))))
    t = stack.truth.wait(timeout=20.0).t
    for _ in range(300):  # the first VPS fixes: a goal may start (at most 30 s of sim time)
        if not c.query("nav/status", {}).not_ready:
            break
        t = stack.truth.wait(lambda msg, t=t: msg.t >= t + 0.1, timeout=10.0).t
    with pytest.raises(InvalidArgument, match=r"inside obstacles\[0\] 'box'"):
        c.query("nav/move_to_point", {"x": 0.65, "y": 0.0})
    done = c.query("nav/move_to_point", {"x": 1.2, "y": 0.0, "wait": True}, timeout=60.0)
    assert done.result == "succeeded", done.message
    assert least[0] > RADIUS  # the footprint never touched the box
    assert stack.diag("sim").wait(timeout=10.0).counters["contacts"] == 0
    status = c.query("nav/status", {})
    assert len(status.plan) > 2 and status.plan[-1] == (1.2, 0.0)
