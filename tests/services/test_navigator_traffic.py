"""The navigator among other robots (their bodies on zenav/field/robots): round one in the way, waiting for one on the goal."""

import math

from tests.support.navigator import NavigatorRig, reply
from zenav.common import codec, keys
from zenav.common import messages as m

REACH = 0.1 + 0.1 + 0.05  # [m] both footprints and the margin


def body(rig, robot, x, y, v=0.0, theta=0.0, way=()):
    """Another robot's body, as its motor sends it."""
    msg = m.Body(t=rig.clock.now(), robot=robot, x=x, y=y, radius=0.1, theta=theta, v=v, way=way)
    rig.bus.publish(keys.field_key("robots"), codec.encode(msg))


def test_a_robot_standing_on_the_way_is_driven_round_on_the_right():
    rig = NavigatorRig()
    rig.pose()
    q = rig.query("nav/move_to_point", {"x": 1.2, "y": 0.0, "wait": True})
    least, side = math.inf, 0.0
    for _ in range(4000):
        if q.replies:
            break
        body(rig, "r2", 0.6, 0.0)  # on the straight way, in the middle
        rig.step()
        least = min(least, math.hypot(rig.x - 0.6, rig.y))
        side = min(side, rig.y)
    rep = reply(q)
    assert rep.result == "succeeded" and math.hypot(rig.x - 1.2, rig.y) < 0.01
    assert least >= REACH  # never closer than both footprints and the margin
    assert side < -REACH + 0.05  # passed it on the right (heading +x: right is -y)
    c = rig.nav.counters.values
    assert c["robot_detours"] >= 1 and c["robot_waits"] == 0 and c["robot_asides"] == 0
    rig.nav.close()


def test_a_robot_standing_on_the_goal_makes_it_wait_saying_why_then_give_up_after_robot_wait():
    rig = NavigatorRig(robot_wait=2.0)
    rig.pose()
    q = rig.query("nav/move_to_point", {"x": 1.0, "y": 0.0, "wait": True})
    why = set()
    for _ in range(3000):
        if q.replies:
            break
        body(rig, "r0", 1.0, 0.0)
        rig.step()
        why |= {s.traffic for s in rig.published("nav/state")}
    rep = reply(q)
    assert rep.result == "aborted" and rep.exit == "stalled"
    assert "waiting for robot r0 to leave the goal" in rep.message and "robot_wait = 2" in rep.message
    assert "waiting for robot r0 to leave the goal" in why
    assert math.hypot(rig.x - 1.0, rig.y) >= REACH  # it stood clear of it
    c = rig.nav.counters.values
    assert c["robot_waits"] == 1 and c["robot_asides"] == 1  # stepped aside once (r0 may wait for it), then waited
    rig.nav.close()


def cross(rig, q, sign):
    """r0 (the right of way) crosses the way 0.6 m ahead at 0.2 m/s, from below (sign 1) or above (-1), to the goal's
    reply: what nav/state said and how close it came."""
    why, y, least = set(), -0.45 * sign, math.inf
    for _ in range(3000):
        if q.replies:
            break
        y = min(max(y + sign * 0.2 * 0.01, -1.0), 1.0)
        body(rig, "r0", 0.6, y, v=0.2 if abs(y) < 1.0 else 0.0, theta=sign * math.pi / 2)
        rig.step()
        why |= {s.traffic for s in rig.published("nav/state")}
        least = min(least, math.hypot(rig.x - 0.6, rig.y - y))
    return why, least


def test_a_robot_crossing_the_way_from_the_left_slows_it_counted_and_said_on_nav_state():
    rig = NavigatorRig()
    rig.pose()
    q = rig.query("nav/move_to_point", {"x": 1.5, "y": 0.0, "wait": True})
    why, least = cross(rig, q, -1.0)
    assert reply(q).result == "succeeded" and least >= REACH
    assert "slowing for robot r0 to pass" in why
    assert rig.nav.counters.values["robot_slowdowns"] >= 1
    rig.nav.close()


def test_a_robot_crossing_the_way_from_the_right_is_passed_behind_keeping_right_at_full_speed():
    rig = NavigatorRig()
    rig.pose()
    q = rig.query("nav/move_to_point", {"x": 1.5, "y": 0.0, "wait": True})
    why, least = cross(rig, q, 1.0)
    assert reply(q).result == "succeeded" and least >= REACH
    c = rig.nav.counters.values
    assert c["robot_detours"] >= 1 and c["robot_slowdowns"] == 0 and why == {""}
    rig.nav.close()


def test_avoid_robots_false_leaves_them_to_the_guard():
    rig = NavigatorRig(avoid_robots=False)
    rig.pose()
    rig.query("nav/move_to_point", {"x": 1.2, "y": 0.0})
    for _ in range(300):
        body(rig, "r2", 0.6, 0.0)
        rig.step()
    assert abs(rig.y) < 0.01  # straight on, at it
    rig.nav.close()


def test_its_commands_tell_its_way_and_another_robots_told_way_comes_in_with_its_body():
    rig = NavigatorRig()
    rig.pose()
    rig.query("nav/move_to_point", {"x": 1.2, "y": 0.5})
    for _ in range(50):
        body(rig, "r2", 0.5, 1.0, v=0.2, way=((0.5, 1.5),))
        rig.step()
    cmds = rig.published("cmd_vel")
    assert cmds and cmds[-1].v > 0.0 and cmds[-1].way == ((1.2, 0.5),)
    assert rig.nav._bodies()[0].way == ((0.5, 1.5),)
    rig.nav.close()
