"""move_to_pose, exits and chained paths through the navigator service (in-memory bus, manual clock)."""

import math

import pytest

from tests.support.navigator import NavigatorRig, reply
from zenav.common import messages as m
from zenav.common.bus import MemoryBus
from zenav.common.clock import ManualClock
from zenav.common.config import ConfigError, Settings
from zenav.services.navigator.service import Navigator


def test_move_to_pose_arrives_with_its_heading_and_says_why_it_ended(rig):
    q = rig.query("nav/move_to_pose", {"x": 0.6, "y": 0.3, "theta": math.pi / 2, "wait": True})
    rep = rig.run_until(q)
    assert rep.result == "succeeded" and rep.exit == "within_tolerance", rep.message
    assert math.hypot(rig.x - 0.6, rig.y - 0.3) <= 0.01 and abs(rig.theta - math.pi / 2) <= 0.0087
    state = rig.published("nav/state")[-1]
    assert state.result == "succeeded" and state.exit == "within_tolerance" and state.goal["type"] == "move_to_pose"
    status = reply(rig.query("nav/status"), m.StatusReply)
    assert status.exit == "within_tolerance"


def test_a_timeout_ends_the_move_with_its_exit(rig):
    rep = rig.run_until(rig.query("nav/move_to_point", {"x": 1.0, "y": 0.0, "timeout": 0.5, "wait": True}))
    assert rep.result == "aborted" and rep.exit == "timeout" and "from the goal" in rep.message
    assert rig.cmd == (0.0, 0.0)


def test_stop_reports_cancelled(rig):
    rig.query("nav/move_to_point", {"x": 1.0, "y": 0.0})
    rig.step(10)
    reply(rig.query("nav/stop"), m.StopReply)
    assert rig.published("nav/state")[-1].exit == "cancelled"


def test_unstable_polar_gains_fail_at_start_naming_the_equation():
    with pytest.raises(ConfigError, match="eq. 8"):
        Navigator(Settings.load(None, navigator={"k_alpha": 2.9, "k_beta": -0.1}), MemoryBus(), ManualClock())


def test_a_path_with_point_tolerances_passes_its_points_without_stopping(rig):
    q = rig.query("nav/follow_path", {"points": [[0.5, 0.0, 0.05], [0.5, 0.5], [0.0, 0.5, 0.01]], "wait": True})
    rep = rig.run_until(q)
    assert rep.result == "succeeded" and rep.exit == "within_tolerance"
    speeds = [c.v for c in rig.published("cmd_vel") if c.t > 0]
    first_zero = speeds.index(0.0)
    assert first_zero > 500 and set(speeds[first_zero:]) == {0.0}  # forward all the way, zero only once it ended


def _drive(start_theta, suffix, request, **cfg):
    """Run one goal to its end from (0, 0, start_theta): (reply, final (x, y, theta), the commands)."""
    rig = NavigatorRig(**cfg)
    rig.theta = start_theta
    rig.pose()
    rep = rig.run_until(rig.query(suffix, {**request, "wait": True}))
    cmds = [(c.v, c.omega) for c in rig.published("cmd_vel")]
    rig.nav.close()
    return rep, (rig.x, rig.y, rig.theta), cmds


MIRRORED = [
    ("nav/move_to_point", {"x": 0.5, "y": 0.3}, {"controller": "pid"}),
    ("nav/move_to_point", {"x": 0.5, "y": 0.3}, {"controller": "polar"}),
    ("nav/move_to_point", {"x": 0.5, "y": 0.3}, {"controller": "proportional"}),
    ("nav/move_to_point", {"x": 0.2, "y": 0.0, "tolerance": 0.02}, {"controller": "pid"}),  # short: locked on at once
    ("nav/move_to_pose", {"x": 0.6, "y": -0.3, "theta": -1.0}, {"pose_controller": "boomerang"}),
    ("nav/move_to_pose", {"x": 0.6, "y": -0.3, "theta": -1.0}, {"pose_controller": "polar"}),
    ("nav/follow_path", {"points": [[0.4, 0.1], [0.5, 0.5], [0.1, 0.6]]}, {"controller": "pid"}),
    ("nav/move_to_point", {"x": 0.5, "y": 0.3, "min_speed": 0.1, "early_exit_range": 0.02}, {"controller": "pid"}),  # chained
    ("nav/move_to_pose", {"x": 0.6, "y": -0.3, "theta": -1.0, "min_speed": 0.1}, {"pose_controller": "boomerang"}),
]


@pytest.mark.parametrize("suffix, request_, cfg", MIRRORED, ids=lambda v: str(v)[:40])
def test_a_backwards_goal_is_the_forward_goal_driven_with_the_back_ahead(suffix, request_, cfg):
    """On the ideal robot a backwards goal from heading th + pi is the forward goal from th, mirrored: the same track
    and the same turn rates, every speed negated, the heading half a turn on (a move_to_pose's theta, the front's)."""
    ahead, (fx, fy, fth), forward = _drive(0.3, suffix, request_, **cfg)
    theta = {"theta": request_["theta"] + math.pi} if "theta" in request_ else {}
    back, (bx, by, bth), backward = _drive(0.3 + math.pi, suffix, {**request_, **theta, "forwards": False}, **cfg)
    assert ahead.result == back.result == "succeeded" and ahead.exit == back.exit, (ahead.message, back.message)
    assert len(forward) == len(backward) > 100
    assert max(abs(f[0] + b[0]) + abs(f[1] - b[1]) for f, b in zip(forward, backward, strict=True)) < 1e-9
    assert math.hypot(fx - bx, fy - by) < 1e-9 and abs(math.remainder(bth - fth - math.pi, math.tau)) < 1e-9
    assert min(v for v, _ in backward) < -0.1  # it drove, backwards


@pytest.mark.parametrize("controller", ["pid", "polar", "proportional"])
@pytest.mark.parametrize("x, y", [(0.5, 0.0), (-0.4, 0.4), (0.3, -0.6)])
def test_a_backwards_move_to_point_backs_onto_the_point_with_every_controller(controller, x, y):
    rig = NavigatorRig(controller=controller)
    rig.pose()
    rep = rig.run_until(rig.query("nav/move_to_point", {"x": x, "y": y, "forwards": False, "wait": True}))
    assert rep.result == "succeeded", rep.message
    assert math.hypot(rig.x - x, rig.y - y) <= 0.01
    speeds = [c.v for c in rig.published("cmd_vel")]
    assert max(speeds) <= 0.0 and min(speeds) < -0.1  # backed all the way, at speed
    back = math.atan2(y, x) + math.pi  # the robot's heading when its back points along the way it came
    assert abs(math.remainder(rig.theta - back, math.tau)) < math.radians(30)
    assert rig.published("nav/state")[-1].goal["forwards"] is False
    rig.nav.close()


@pytest.mark.parametrize("side, pivot", [("left", 1), ("right", -1)])
def test_a_swing_turns_about_the_wheel_that_stays_still(rig, side, pivot):
    """LemLib's swingToHeading: the locked wheel's contact point is where it was, and the robot ends at the heading."""
    half = rig.bot.robot.track_width / 2.0

    def wheel():
        return rig.x - pivot * half * math.sin(rig.theta), rig.y + pivot * half * math.cos(rig.theta)

    before = wheel()
    rep = rig.run_until(rig.query("nav/swing_to_heading", {"heading": math.pi / 2, "side": side, "direction": "ccw", "wait": True}))
    assert rep.result == "succeeded" and abs(math.remainder(rig.theta - math.pi / 2, math.tau)) <= 0.0175
    assert math.dist(wheel(), before) < 0.002 and math.hypot(rig.x, rig.y) > 0.05  # the still wheel stayed; the robot moved
    assert rig.published("nav/state")[-1].goal["side"] == side


def test_turn_to_point_backwards_turns_the_back_to_the_point(rig):
    rep = rig.run_until(rig.query("nav/turn_to_point", {"x": 1.0, "y": 1.0, "forwards": False, "wait": True}))
    assert rep.result == "succeeded"
    assert abs(math.remainder(rig.theta - math.radians(-135), math.tau)) <= 0.0087
