"""The navigator among the [field] obstacles: goals into one refused naming it, goals behind one planned round it."""

import math

import pytest

from tests.support.navigator import NavigatorRig, reply
from zenav.common import codec
from zenav.common import messages as m
from zenav.common.field import polygon_shape

BOX = [[0.55, -0.1], [0.75, -0.1], [0.75, 0.1], [0.55, 0.1]]
FIELD = {"obstacles": [{"name": "box", "polygon": BOX}], "margin": 0.02}
RADIUS = 0.1  # [robot] radius, the default


@pytest.fixture
def rig():
    r = NavigatorRig(field=FIELD)
    r.pose()
    yield r
    r.nav.close()


def drive(rig, q):
    """Step to the reply, recording the robot's least distance from the box."""
    box, least = polygon_shape("box", BOX), math.inf
    for _ in range(6000):
        if q.replies:
            break
        rig.step()
        least = min(least, box.clearance(rig.x, rig.y))
    return reply(q), least


def test_a_goal_behind_the_box_is_reached_round_it_the_footprint_never_touching(rig):
    rep, least = drive(rig, rig.query("nav/move_to_point", {"x": 1.2, "y": 0.0, "wait": True}))
    assert rep.result == "succeeded" and math.hypot(rig.x - 1.2, rig.y) < 0.01
    assert least > RADIUS  # the footprint never touched the box (the margin held the tracking error)
    [plan] = rig.published("nav/plan")
    assert plan.planned and len(plan.points) > 2 and plan.points[-1] == (1.2, 0.0)
    assert plan.clearance >= RADIUS + 0.02 - 1e-6 and plan.length > 1.2
    status = reply(rig.query("nav/status", {}), m.StatusReply)
    assert status.plan == plan.points


def test_a_goal_inside_the_box_is_refused_naming_it(rig):
    rep = reply(rig.query("nav/move_to_point", {"x": 0.65, "y": 0.0}))
    assert rep.error == "invalid_argument" and "inside obstacles[0] 'box'" in rep.message
    rep = reply(rig.query("nav/move_to_point", {"x": 0.45, "y": 0.0}))  # clear of the box, not of the footprint
    assert rep.error == "invalid_argument" and "0.100 m from obstacles[0] 'box'" in rep.message
    rep = reply(rig.query("nav/follow_path", {"points": [[0.3, 0.4], [0.65, 0.05]], "plan": False}))
    assert rep.error == "invalid_argument" and rep.message.startswith("points[1]:")
    assert rig.published("cmd_vel") == []


def test_plan_false_drives_straight(rig):
    rig.query("nav/move_to_point", {"x": 1.2, "y": 0.0, "plan": False})
    [plan] = rig.published("nav/plan")
    assert not plan.planned and plan.points == [(1.2, 0.0)] and plan.clearance == 0.0  # through the box


def test_follow_path_keeps_the_users_points_and_plans_detours_between(rig):
    q = rig.query("nav/follow_path", {"points": [[0.3, 0.0], [1.2, 0.0], [1.2, 0.4]], "wait": True})
    rep, least = drive(rig, q)
    assert rep.result == "succeeded" and least > RADIUS
    [plan] = rig.published("nav/plan")
    assert plan.points[0] == (0.3, 0.0) and (1.2, 0.0) in plan.points and plan.points[-1] == (1.2, 0.4)
    assert len(plan.points) > 3


def test_move_to_pose_round_the_box_arrives_with_its_heading(rig):
    rep, least = drive(rig, rig.query("nav/move_to_pose", {"x": 1.2, "y": 0.0, "theta": 1.0, "wait": True}))
    assert rep.result == "succeeded" and least > RADIUS and abs(rig.theta - 1.0) < 0.02


def test_a_start_overlapping_the_box_is_refused_saying_why(rig):
    rig.x = 0.5  # the footprint's edge 5 cm into the box
    rig.pose()
    rep = reply(rig.query("nav/move_to_point", {"x": 0.0, "y": 0.5}))
    assert rep.error == "invalid_argument" and "overlaps obstacles[0] 'box'" in rep.message
    rig.x = 0.44  # 11 cm off: within the margin, clear of the footprint: it steps out and goes
    rig.pose()
    rep, least = drive(rig, rig.query("nav/move_to_point", {"x": 1.2, "y": 0.0, "wait": True}))
    assert rep.result == "succeeded" and least > RADIUS


def test_what_the_motors_guard_holds_back_shows_on_nav_state(rig):
    rig.bus.publish(
        "zenav/r1/motor/guard", codec.encode(m.GuardState(t=rig.clock.now(), reason="robot r2 0.004 m ahead", v=0.0, stopped=True))
    )
    rig.nav.drain()
    assert rig.published("nav/state")[-1].guard == "robot r2 0.004 m ahead"
    rig.bus.publish("zenav/r1/motor/guard", codec.encode(m.GuardState(t=rig.clock.now(), reason="", v=0.2)))
    rig.nav.drain()
    assert rig.published("nav/state")[-1].guard == ""
