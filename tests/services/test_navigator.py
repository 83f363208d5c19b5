"""The navigator service on the in-memory bus with a manual clock, driving the world's robot."""

import math

import msgpack
import pytest

from tests.support.navigator import NavigatorRig, long_path, reply
from zenav.common import codec
from zenav.common import messages as m
from zenav.common.app import main
from zenav.common.bus import MemoryBus
from zenav.common.clock import ManualClock, SimClock
from zenav.common.config import ConfigError, Settings
from zenav.services.navigator.service import Navigator


def test_move_to_point_waits_and_arrives_stopped(rig):
    q = rig.query("nav/move_to_point", {"x": 0.5, "y": 0.2, "wait": True})
    assert q.replies == []
    rep = rig.run_until(q)
    assert rep.result == "succeeded" and rep.goal_id == 1 and rep.speed == pytest.approx(0.2)
    assert math.hypot(rig.x - 0.5, rig.y - 0.2) < 0.01
    assert math.hypot(rep.pose.x - 0.5, rep.pose.y - 0.2) < 0.01
    assert rig.cmd == (0.0, 0.0)
    cmds = rig.published("cmd_vel")
    assert all(c.t > 0 for c in cmds) and max(c.v for c in cmds) == pytest.approx(0.2, abs=1e-3)
    states = [s.state for s in rig.published("nav/state")]
    assert [a for a, b in zip(states, [None] + states) if a != b] == ["STOPPED", "MOVING_TO_POINT", "STOPPED"]
    assert rig.published("nav/state")[-1].result == "succeeded"


def test_cmd_vel_carries_the_pose_t(rig):
    rig.query("nav/move_to_point", {"x": 1.0, "y": 0.0})
    rig.step(3)
    assert rig.published("cmd_vel")[-1].t == pytest.approx(rig.clock.now())


@pytest.mark.parametrize("control_on", ["pose", "odom"])
def test_a_navigator_behind_its_input_acts_on_the_newest(control_on):
    rig = NavigatorRig(control_on=control_on)
    rig.pose()
    rig.query("nav/move_to_point", {"x": 1.0, "y": 0.0})
    rig.step(3)
    before = len(rig.published("cmd_vel"))
    for _ in range(3):  # three samples come before the navigator gets to any
        rig.clock.advance(0.01)
        msg = m.Odom if control_on == "odom" else m.Pose
        rig.bus.publish(f"zenav/r1/{control_on}", codec.encode(msg(t=rig.clock.now(), x=rig.x, y=rig.y, theta=rig.theta, v=0.2, omega=0.0)))
    rig.nav.drain()
    assert [c.t for c in rig.published("cmd_vel")[before:]] == [pytest.approx(rig.clock.now())]
    assert rig.nav.counters.values["dropped_superseded"] == 2
    rig.nav.close()


def test_turn_to_heading_turns_without_overshoot(rig):
    q = rig.query("nav/turn_to_heading", {"heading": 1.5, "wait": True})
    seen = []
    for _ in range(500):
        if q.replies:
            break
        rig.step()
        seen.append(rig.theta)
    assert reply(q).result == "succeeded"
    assert abs(rig.theta - 1.5) < 0.0175 and max(seen) < 1.5 + 0.0175
    assert math.hypot(rig.x, rig.y) < 1e-9


def test_turn_to_point_faces_it(rig):
    rep = rig.run_until(rig.query("nav/turn_to_point", {"x": -1.0, "y": -1.0, "wait": True}))
    assert rep.result == "succeeded"
    assert abs(math.remainder(rig.theta - math.atan2(-1, -1), 2 * math.pi)) < 0.0175


def test_turn_to_point_where_the_robot_is_is_refused(rig):
    err = reply(rig.query("nav/turn_to_point", {"x": 0.0, "y": 0.0}))
    assert err.error == "invalid_argument" and "x, y" in err.message


def test_move_straight_holds_the_line_and_stops_at_the_distance(rig):
    rig.theta = 0.3
    rig.pose()
    q = rig.query("nav/move_straight", {"speed": 0.15, "distance": 0.4, "wait": True})
    rig.step(20)
    rig.y += 0.02  # a shove to the left of the line
    for _ in range(2000):
        if rig.nav.machine.result:
            break
        rig.step()
    assert rig.nav.machine.result == "succeeded" and reply(q).result == "succeeded"
    along = rig.x * math.cos(0.3) + rig.y * math.sin(0.3)
    lateral = -rig.x * math.sin(0.3) + rig.y * math.cos(0.3)
    assert along == pytest.approx(0.4, abs=0.005) and abs(lateral) < 0.005


def test_move_straight_backwards_without_distance_runs_until_stop(rig):
    rep = reply(rig.query("nav/move_straight", {"speed": -0.1}))
    assert rep.state == "MOVING_STRAIGHT"
    rig.step(100)
    assert rig.x == pytest.approx(-0.1, abs=0.01) and abs(rig.y) < 1e-3
    stop = reply(rig.query("nav/stop"), m.StopReply)
    assert stop.state == "STOPPED" and rig.cmd == (0.0, 0.0)
    assert rig.published("cmd_vel")[-1].t == 0.0  # "now": not computed from a pose
    assert rig.nav.machine.result == "cancelled"


def test_follow_path_in_order_with_feedback(rig):
    q = rig.query("nav/follow_path", {"points": [[0.3, 0.0], [0.3, 0.3], [0.0, 0.3]], "wait": True})
    next_points = set()
    for _ in range(6000):
        if q.replies:
            break
        rig.step()
        next_points.add(rig.published("nav/state")[-1].next_point)
    rep = reply(q)
    assert rep.result == "succeeded" and math.hypot(rig.x, rig.y - 0.3) < 0.01
    assert {0, 1, 2} <= next_points


def test_nav_state_at_5_hz_with_feedback(rig):
    rig.query("nav/move_to_point", {"x": 1.0, "y": 0.0})
    n0 = len(rig.published("nav/state"))
    rig.step(100)
    states = rig.published("nav/state")[n0:]
    assert len(states) == 5
    s = states[-1]
    assert s.state == "MOVING_TO_POINT" and s.result is None and s.goal["type"] == "move_to_point"
    assert s.distance_remaining == pytest.approx(1.0 - rig.x, abs=0.01)
    assert s.eta == pytest.approx(s.distance_remaining / 0.2) and s.elapsed == pytest.approx(1.0, abs=0.02)
    assert abs(s.heading_error) < 0.01 and abs(s.cross_track_error) < 1e-6


def test_status(rig):
    rig.query("nav/move_to_point", {"x": 1.0, "y": 0.0, "speed": 0.1})
    rig.step(10)
    st = reply(rig.query("nav/status"), m.StatusReply)
    assert st.state == "MOVING_TO_POINT" and st.is_moving and st.goal_id == 1 and st.result is None
    assert st.goal["speed"] == pytest.approx(0.1) and st.pose.x == pytest.approx(rig.x)
    assert st.distance_remaining == pytest.approx(1.0 - rig.x, abs=0.002)


def test_preemption_answers_the_old_waiter_cancelled_without_a_stop(rig):
    q1 = rig.query("nav/move_to_point", {"x": 1.0, "y": 0.0, "wait": True})
    rig.step(50)
    n = len(rig.published("cmd_vel"))
    q2 = rig.query("nav/move_to_point", {"x": 1.0, "y": 0.5})
    old = reply(q1)
    assert old.result == "cancelled" and "preempted" in old.message and old.goal_id == 1
    assert reply(q2).goal_id == 2
    rig.step()
    assert all(c.v > 0 for c in rig.published("cmd_vel")[n:])  # a handover: no zero in between


def test_stop_answers_the_waiter_and_commands_zero_at_once(rig):
    q = rig.query("nav/move_to_point", {"x": 1.0, "y": 0.0, "wait": True})
    rig.step(50)
    reply(rig.query("nav/stop"), m.StopReply)
    assert reply(q).result == "cancelled" and rig.cmd == (0.0, 0.0)


def test_stale_pose_aborts_and_stops(rig):
    q = rig.query("nav/move_to_point", {"x": 1.0, "y": 0.0, "wait": True})
    rig.step(20)
    for _ in range(100):
        if q.replies:
            break
        rig.step(poses=False)
    rep = reply(q)
    assert rep.result == "aborted" and "stale" in rep.message and rig.cmd == (0.0, 0.0)
    assert 0.5 < rig.clock.now() - rig.nav.machine.pose.t <= 0.56  # found within a check period


def test_no_progress_aborts(rig):
    rig.moving = False
    q = rig.query("nav/move_to_point", {"x": 1.0, "y": 0.0, "wait": True})
    rep = rig.run_until(q, max_s=7.0)
    assert rep.result == "aborted" and "no progress" in rep.message and rig.cmd == (0.0, 0.0)
    assert 5.0 <= rig.clock.now() - 100.0 <= 5.2


def test_lease_lost_cancels_the_goal_and_stops(rig):
    token = rig.bus.token("zenav/r1/lease/me")
    q = rig.query("nav/move_to_point", {"x": 1.0, "y": 0.0, "wait": True, "lease": "zenav/r1/lease/me"})
    rig.step(20)
    assert rig.nav.machine.state == "MOVING_TO_POINT"
    token.undeclare()
    rig.step()
    rep = reply(q)
    assert rep.result == "aborted" and rep.message == "lease lost: zenav/r1/lease/me" and rig.cmd == (0.0, 0.0)


def test_a_chained_goals_held_command_ends_at_once_when_its_lease_goes(rig):
    token = rig.bus.token("zenav/r1/lease/me")
    chained = {"x": 0.5, "y": 0.0, "wait": True, "lease": "zenav/r1/lease/me", "min_speed": 0.15, "early_exit_range": 0.05}
    q = rig.query("nav/move_to_point", chained)
    rep = rig.run_until(q, max_s=10.0)
    assert rep.exit == "chained" and rig.nav.machine.coasting and rig.cmd[0] >= 0.15  # held at speed for the next goal
    token.undeclare()  # the program died before it sent one
    rig.step(poses=False)
    assert rig.cmd == (0.0, 0.0) and not rig.nav.machine.coasting  # not after chain_time: now


def test_lease_seen_later_starts_the_goal(rig):
    q = rig.query("nav/move_to_point", {"x": 1.0, "y": 0.0, "lease": "zenav/r1/lease/late"})
    rig.step(10)
    assert q.replies == [] and rig.nav.machine.state == "STOPPED"
    rig.bus.token("zenav/r1/lease/late")
    rig.step()
    assert reply(q).state == "MOVING_TO_POINT"


def test_a_newer_goal_supersedes_one_waiting_for_its_lease(rig):
    q1 = rig.query("nav/move_to_point", {"x": 1.0, "y": 0.0, "lease": "zenav/r1/lease/slow"})
    q2 = rig.query("nav/move_to_point", {"x": 0.0, "y": 1.0})
    assert reply(q1).error == "unavailable" and reply(q2).goal_id == 1
    rig.bus.token("zenav/r1/lease/slow")
    rig.step()
    assert rig.nav.machine.goal_id == 1 and rig.nav.machine.goal.points == ((0.0, 1.0),)


def test_lease_never_seen_is_unavailable(rig):
    q = rig.query("nav/move_to_point", {"x": 1.0, "y": 0.0, "lease": "zenav/r1/lease/nobody"})
    rig.step(60)
    err = reply(q)
    assert err.error == "unavailable" and "zenav/r1/lease/nobody" in err.message
    assert rig.nav.machine.state == "STOPPED" and rig.cmd == (0.0, 0.0)


def test_wildcard_lease_is_refused(rig):
    err = reply(rig.query("nav/move_to_point", {"x": 1.0, "y": 0.0, "lease": "zenav/**"}))
    assert err.error == "invalid_argument" and "lease" in err.message


@pytest.mark.parametrize("service", ["motor", "localizer", "odometry"])
def test_a_needed_service_going_aborts_the_goal(rig, service):
    token = rig.bus.token(f"zenav/r1/alive/{service}")
    q = rig.query("nav/move_to_point", {"x": 1.0, "y": 0.0, "wait": True})
    rig.step(10)
    token.undeclare()
    rig.nav.drain()
    rep = reply(q)
    assert rep.result == "aborted" and rep.message == f"{service} service gone" and rig.cmd == (0.0, 0.0)
    rig.bus.token(f"zenav/r1/alive/{service}")
    rig.step(10)
    assert rig.nav.machine.state == "STOPPED" and rig.cmd == (0.0, 0.0)  # back: no goal resumes


def test_goal_without_pose_is_unavailable():
    r = NavigatorRig()
    err = reply(r.query("nav/move_to_point", {"x": 1.0, "y": 0.0}))
    assert err.error == "unavailable" and "no pose" in err.message
    r.nav.close()


def test_goal_on_a_stale_pose_is_unavailable(rig):
    rig.clock.advance(1.0)
    err = reply(rig.query("nav/turn_to_heading", {"heading": 1.0}))
    assert err.error == "unavailable" and "stale" in err.message


@pytest.mark.parametrize(
    "suffix, payload, field",
    [
        ("nav/move_to_point", {"y": 1.0}, "x"),
        ("nav/move_to_point", {"x": "one", "y": 1.0}, "x"),
        ("nav/move_to_point", {"x": math.nan, "y": 1.0}, "x"),
        ("nav/move_to_point", {"x": 1.0, "y": 1.0, "tolerance": -0.1}, "tolerance"),
        ("nav/move_to_point", {"x": 1.0, "y": 1.0, "tolerence": 0.1}, "tolerence"),
        ("nav/turn_to_heading", {"heading": math.inf}, "heading"),
        ("nav/follow_path", {"points": []}, "points"),
        ("nav/follow_path", {"points": [[1.0]]}, "points"),
        ("nav/move_straight", {"speed": 0.0}, "speed"),
        ("nav/move_straight", {"speed": 0.1, "distance": -1.0}, "distance"),
        ("nav/stop", {"now": True}, "now"),
    ],
)
def test_bad_payloads_name_the_field(rig, suffix, payload, field):
    err = reply(rig.query(suffix, payload))
    assert err.error == "invalid_argument" and field in err.message


@pytest.mark.parametrize(
    "params, field",
    [
        ({"y": "1"}, "x"),
        ({"x": "one", "y": "1"}, "x"),
        ({"x": "nan", "y": "0"}, "x"),
        ({"x": "1", "y": "0", "tolerance": "-1"}, "tolerance"),
    ],
)
def test_bad_selector_parameters_name_the_field(rig, params, field):
    err = reply(rig.query("nav/move_to_point", params=params))
    assert err.error == "invalid_argument" and field in err.message


def test_selector_parameters_drive_the_robot(rig):
    rep = reply(rig.query("nav/move_to_point", params={"x": "0.2", "y": "0", "wait": "false"}))
    assert rep.state == "MOVING_TO_POINT"
    rep = reply(rig.query("nav/follow_path", params={"points": "[[0.1,0],[0.2,0.1]]"}))
    assert rep.state == "FOLLOWING_PATH" and rep.goal_id == 2


def test_bad_msgpack_is_invalid_argument(rig):
    q = rig.bus.query("zenav/r1/nav/move_to_point", msgpack.packb([1, 2]))
    rig.nav.drain()
    assert reply(q).error == "invalid_argument"


def test_speeds_above_the_limits_are_clamped_and_reported(rig):
    assert reply(rig.query("nav/move_to_point", {"x": 1.0, "y": 0.0, "speed": 5.0})).speed == pytest.approx(0.3)
    assert reply(rig.query("nav/turn_to_heading", {"heading": 1.0, "speed": 50.0})).speed == pytest.approx(3.0)
    assert reply(rig.query("nav/move_straight", {"speed": -9.0})).speed == pytest.approx(-0.3)
    rig.step(10)
    assert max(abs(c.v) for c in rig.published("cmd_vel")) <= 0.3 + 1e-9


@pytest.mark.parametrize("control_on", ["pose", "odom"])
def test_out_of_order_input_is_dropped(control_on):
    rig = NavigatorRig(control_on=control_on)
    rig.pose()
    rig.step(2)
    msg = m.Odom if control_on == "odom" else m.Pose
    rig.bus.publish(f"zenav/r1/{control_on}", codec.encode(msg(t=50.0, x=5.0, y=5.0, theta=0.0, v=0.0, omega=0.0)))
    rig.nav.drain()
    assert rig.nav.counters.values["dropped_stale"] == 1 and rig.nav.machine.pose.x == pytest.approx(0.0)
    rig.nav.close()


def _origin(bus, t):
    """The robot at the origin at t: its pose, then its odom sample (the odometry's frame the map's)."""
    bus.publish("zenav/r1/pose", codec.encode(m.Pose(t=t, x=0.0, y=0.0, theta=0.0, v=0.0, omega=0.0)))
    bus.publish("zenav/r1/odom", codec.encode(m.Odom(t=t, x=0.0, y=0.0, theta=0.0, v=0.0, omega=0.0)))


@pytest.mark.parametrize("control_on", ["pose", "odom"])
def test_sim_restart_aborts_the_goal_and_takes_the_new_poses(control_on):
    bus, clock = MemoryBus(), SimClock()
    nav = Navigator(Settings.load(None, navigator={"control_on": control_on}), bus, clock)
    nav.start()
    bus.publish("zenav/r1/clock", codec.encode(m.Clock(t=50.0)))
    _origin(bus, 50.0)
    q = bus.query("zenav/r1/nav/move_to_point", codec.encode({"x": 1.0, "y": 0.0, "wait": True}))
    nav.drain()
    bus.publish("zenav/r1/clock", codec.encode(m.Clock(t=0.01, instance="sim-2")))  # a new sim instance
    _origin(bus, 0.01)
    nav.drain()
    rep = reply(q)
    assert rep.result == "aborted" and "restarted" in rep.message
    assert nav.machine.pose.t == 0.01 and nav.counters.values["dropped_stale"] == 0
    nav.close()


def test_shutdown_answers_waiters_and_stops(rig):
    q = rig.query("nav/move_to_point", {"x": 1.0, "y": 0.0, "wait": True})
    rig.step(10)
    rig.nav.close()
    assert reply(q).result == "aborted" and rig.published("cmd_vel")[-1].v == 0.0


def test_liveliness_token():
    r = NavigatorRig()
    assert "zenav/r1/alive/navigator" in r.bus.alive()
    r.nav.close()


def test_unstable_gains_fail_at_start_naming_them():
    with pytest.raises(ConfigError, match="k_alpha"):
        Navigator(Settings.load(None, navigator={"k_alpha": 1.0}), MemoryBus(), ManualClock())


def test_help(capsys):
    with pytest.raises(SystemExit) as e:
        main(Navigator, ["--help"])
    assert e.value.code == 0 and "zenav-navigator" in capsys.readouterr().out


def test_a_10k_point_path_is_followed_from_its_first_point(rig):
    rep = reply(rig.query("nav/follow_path", long_path(10_000)))
    assert rep.state == "FOLLOWING_PATH"
    rig.step(5)
    fb = rig.nav.machine.feedback(rig.clock.now())
    # Points 0.1 mm apart: those within the 5 cm waypoint tolerance (about 500) are passed at once, no more.
    assert fb.distance_remaining == pytest.approx(1.0 - rig.x, abs=1e-3) and 0 < fb.next_point < 1000


def test_a_path_over_the_configured_length_is_refused_naming_the_limit():
    r = NavigatorRig(max_path_points=100)
    r.pose()
    err = reply(r.query("nav/follow_path", long_path(101)))
    assert err.error == "invalid_argument" and "max_path_points = 100" in err.message
    assert reply(r.query("nav/follow_path", long_path(100))).state == "FOLLOWING_PATH"
    r.nav.close()


def test_a_wildcard_get_reaches_only_the_read_only_queries(rig):
    rig.query("nav/move_to_point", {"x": 1.0, "y": 0.0})
    rig.step(10)
    q = rig.query("**")
    replies = {ok for ok, _ in q.replies}
    assert rig.nav.machine.state == "MOVING_TO_POINT" and replies == {True, False}
    [status] = [codec.decode(d, m.StatusReply) for ok, d in q.replies if ok]
    assert status.state == "MOVING_TO_POINT"
    assert rig.nav.counters.values["wildcard_refused"] == 8  # seven goals and stop
    assert rig.cmd[0] > 0.0  # the stop it reached did not command zero either


@pytest.mark.parametrize(
    "suffix, payload, words",
    [
        ("nav/move_to_point", {"x": 3.5, "y": 0.0}, "x_max = 3.0"),
        ("nav/move_to_point", {"x": 0.0, "y": -1.5}, "y_min = -1.0"),
        ("nav/follow_path", {"points": [[1.0, 0.0], [1.0, 4.0]]}, "points[1]"),
        ("nav/move_straight", {"speed": -0.1, "distance": 1.5}, "x_min = -1.0"),
    ],
)
def test_a_target_outside_the_field_is_refused_naming_the_bound(rig, suffix, payload, words):
    err = reply(rig.query(suffix, payload))
    assert err.error == "invalid_argument" and words in err.message
    assert rig.nav.machine.state == "STOPPED"


def test_the_field_can_be_turned_off():
    r = NavigatorRig(field={"enabled": False})
    r.pose()
    assert reply(r.query("nav/move_to_point", {"x": 30.0, "y": 0.0})).state == "MOVING_TO_POINT"
    r.nav.close()


def test_leaving_the_field_aborts_the_goal_and_stops(rig):
    q = rig.query("nav/move_straight", {"speed": 0.3, "wait": True})
    rig.step(10)
    rig.x = 3.05  # pushed over the edge
    rig.step()
    rep = reply(q)
    assert rep.result == "aborted" and rep.message.startswith("left the field") and rig.cmd == (0.0, 0.0)


def test_a_robot_stopped_past_the_edge_is_driven_back_in(rig):
    q = rig.query("nav/move_straight", {"speed": 0.3, "wait": True})
    rig.step(10)
    rig.x = 3.012  # over the edge
    rig.step()
    assert reply(q).message.startswith("left the field")
    rep = rig.run_until(rig.query("nav/move_to_point", {"x": 2.5, "y": 0.0, "wait": True}))  # turns in place out there first
    assert rep.result == "succeeded", rep.message
    assert math.hypot(rig.x - 2.5, rig.y) < 0.02
    q = rig.query("nav/move_straight", {"speed": 0.3, "wait": True})  # inside again: the bounds hold
    rep = rig.run_until(q)
    assert rep.message.startswith("left the field") and "farther out" not in rep.message and rig.x < 3.01


def test_move_straight_without_a_distance_ends_after_the_time_limit():
    r = NavigatorRig(straight_max_time=2.0)
    r.pose()
    q = r.query("nav/move_straight", {"speed": 0.1, "wait": True})
    rep = r.run_until(q, max_s=3.0)
    assert rep.result == "aborted" and "straight_max_time = 2 s" in rep.message and r.cmd == (0.0, 0.0)
    assert 2.0 <= r.clock.now() - 100.0 <= 2.1
    r.nav.close()


def test_diag_reports_error_while_the_motor_is_gone(rig):
    token = rig.bus.token("zenav/r1/alive/motor")
    rig.step(2)
    assert rig.nav.status == "ok"
    token.undeclare()
    rig.nav.drain()
    assert rig.nav.status == "error" and "motor" in rig.nav.status_message
    err = reply(rig.query("nav/move_to_point", {"x": 1.0, "y": 0.0}))
    assert err.error == "unavailable" and "motor" in err.message
    rig.bus.token("zenav/r1/alive/motor")
    rig.step()
    assert rig.nav.status == "ok" and reply(rig.query("nav/move_to_point", {"x": 1.0, "y": 0.0})).goal_id == 1


def test_diag_reports_error_while_a_goal_is_wanted_without_a_pose():
    r = NavigatorRig()
    assert reply(r.query("nav/move_to_point", {"x": 1.0, "y": 0.0})).error == "unavailable"
    r.step(10, poses=False)
    diag = r.nav.diag(r.clock.now())
    assert diag.status == "error" and "no pose" in diag.message
    r.step()  # a pose comes: the goal can be driven again
    assert r.nav.status == "ok"
    r.nav.close()


def test_a_stale_pose_under_a_running_goal_is_an_error_until_poses_return(rig):
    rig.query("nav/move_to_point", {"x": 1.0, "y": 0.0})
    rig.step(60, poses=False)
    assert rig.nav.machine.result == "aborted" and rig.nav.status == "error" and "stale" in rig.nav.status_message
    rig.step()
    assert rig.nav.status == "ok"


UNCERTAIN = (1e-4, 0.0, 0.0, 0.0, 1e-4, 0.0, 0.0, 0.0, 0.36**2)  # heading sigma 0.36 rad: past the default 0.35


def test_without_a_vps_an_uncertain_pose_drives_and_is_reported(rig, caplog):
    """A robot on odometry alone (no vps, as the robot profile): its heading sigma grows with every metre; the goal
    drives, and nav/state says how uncertain the pose is."""
    rig.cov = UNCERTAIN
    rig.pose()
    rep = rig.run_until(rig.query("nav/move_to_point", {"x": 0.5, "y": 0.0, "wait": True}))
    assert rep.result == "succeeded", rep
    state = rig.published("nav/state")[-1]
    assert state.heading_sigma == pytest.approx(0.36) and state.position_sigma == pytest.approx(0.01)
    st = reply(rig.query("nav/status"), m.StatusReply)
    assert st.not_ready == "" and st.heading_sigma == pytest.approx(0.36)
    warned = [r.message for r in caplog.records if "uncertain" in r.message]
    assert len(warned) == 1 and "heading sigma 0.360 rad > 0.350 rad" in warned[0], warned


def test_with_a_vps_an_uncertain_pose_refuses_and_aborts(rig):
    token = rig.bus.token("zenav/r1/alive/vps")  # a camera stack: the fixes keep the pose certain, and their loss shows
    rig.cov = UNCERTAIN
    rig.pose()
    err = reply(rig.query("nav/move_to_point", {"x": 0.5, "y": 0.0}))
    assert err.error == "unavailable" and "heading sigma 0.360 rad > 0.350 rad" in err.message, err
    rig.cov = m.ZERO_COV
    rig.pose()
    q = rig.query("nav/move_to_point", {"x": 0.5, "y": 0.0, "wait": True})
    rig.step(10)
    rig.cov = UNCERTAIN
    rep = rig.run_until(q)
    assert rep.result == "aborted" and "pose too uncertain" in rep.message, rep
    token.undeclare()
    rig.step(1)
    assert reply(rig.query("nav/move_to_point", {"x": 0.5, "y": 0.0})).error == "unavailable"  # a vps seen once: still gated
