"""The navigator's control loop on odometry ([navigator] control_on = "odom"): each odom sample is steered on in the
map frame, by the correction of the newest pose paired with the odom sample of its t."""

import math

import pytest

from tests.support.navigator import NavigatorRig, reply
from zenav.common import codec
from zenav.common import messages as m


@pytest.fixture
def rig():
    r = NavigatorRig(control_on="odom")
    r.odom_frame = (1.0, 2.0, -0.4)
    r.pose()
    yield r
    r.nav.close()


def test_before_a_pose_pairs_no_goal_drives():
    r = NavigatorRig(control_on="odom")
    for _ in range(5):  # odom flows, no pose
        r.clock.advance(0.01)
        r.odom()
    err = reply(r.query("nav/move_to_point", {"x": 1.0, "y": 0.0}))
    assert err.error == "unavailable" and "no pose" in err.message
    assert r.published("cmd_vel") == []
    r.nav.close()


def test_it_drives_on_odom_by_the_correction_and_each_command_carries_the_odom_t(rig):
    q = rig.query("nav/move_to_point", {"x": 0.5, "y": 0.2, "wait": True})
    published_at = []
    for _ in range(3000):
        if q.replies:
            break
        rig.bot.drive(*rig.cmd, 0.01)
        rig.clock.advance(0.01)
        rig.odom()  # the command goes out here, before the pose of its t
        published_at.append(rig.published("cmd_vel")[-1].t)
        assert published_at[-1] == pytest.approx(rig.clock.now())
        assert rig.nav.machine.pose.x == pytest.approx(rig.x, abs=1e-9)  # the odom frame's offset undone
        rig.localize()
    rep = reply(q)
    assert rep.result == "succeeded" and math.hypot(rig.x - 0.5, rig.y - 0.2) < 0.01


def test_a_fix_moves_the_pose_steered_on_from_the_next_odom_sample(rig):
    rig.query("nav/move_straight", {"speed": 0.1})
    rig.step(10)
    rig.clock.advance(0.01)
    rig.odom()
    before = rig.nav.machine.pose
    rig.odom_frame = (rig.odom_frame[0], rig.odom_frame[1] + 0.05, rig.odom_frame[2])  # a fix: 5 cm left
    rig.bot.state = rig.bot.state._replace(y=rig.y + 0.05)  # the pose moves, the odometry's does not
    rig.localize()  # the pose of the odom sample's t, with the fix
    assert rig.nav.machine.pose.y == pytest.approx(before.y + 0.05, abs=1e-9)  # the newest pose, at once
    assert rig.published("cmd_vel")[-1].t == before.t  # no command until the next sample
    rig.clock.advance(0.01)
    rig.odom()
    steered = rig.nav.machine.pose
    assert steered.t == pytest.approx(rig.clock.now()) and steered.y == pytest.approx(rig.y, abs=1e-9)


def test_poses_that_stop_while_odom_flows_are_stale(rig):
    """The localizer hangs: its pose's age counts, however fresh the odometry."""
    rig.query("nav/move_to_point", {"x": 1.0, "y": 0.0})
    for _ in range(60):
        rig.bot.drive(*rig.cmd, 0.01)
        rig.clock.advance(0.01)
        rig.odom()
    assert rig.nav.machine.result == "aborted" and "stale" in rig.nav.machine.message
    assert rig.cmd == (0.0, 0.0) and rig.nav.status == "error"
    err = reply(rig.query("nav/move_to_point", {"x": 1.0, "y": 0.0}))
    assert err.error == "unavailable" and "stale" in err.message
    rig.step()  # the poses return
    assert rig.nav.status == "ok"


def test_the_uncertainty_comes_from_the_newest_pose(rig):
    rig.bus.token("zenav/r1/alive/vps")  # the fixes keep the pose certain
    rig.nav.drain()
    rig.query("nav/move_straight", {"speed": 0.1})
    rig.step(5)
    rig.cov = (1e-4, 0.0, 0.0, 0.0, 1e-4, 0.0, 0.0, 0.0, 0.36**2)  # past max_heading_sigma
    rig.clock.advance(0.01)
    rig.odom()
    assert rig.nav.machine.pose.sigma_theta == 0.0
    rig.localize()
    assert rig.nav.machine.pose.sigma_theta == pytest.approx(0.36)
    rig.clock.advance(0.06)
    rig.nav.drain()
    assert rig.nav.machine.result == "aborted" and "heading sigma" in rig.nav.machine.message


def test_a_pose_out_of_order_is_dropped_and_the_correction_kept(rig):
    rig.step(3)
    pose = m.Pose(t=rig.clock.now() - 0.02, x=5.0, y=5.0, theta=0.0, v=0.0, omega=0.0)
    rig.bus.publish("zenav/r1/pose", codec.encode(pose))
    rig.nav.drain()
    assert rig.nav.counters.values["dropped_stale"] == 1
    rig.clock.advance(0.01)
    rig.odom()
    assert rig.nav.machine.pose.x == pytest.approx(rig.x, abs=1e-9)


def test_control_on_pose_reads_no_odom():
    r = NavigatorRig(control_on="pose")
    r.pose()
    r.bus.publish("zenav/r1/odom", codec.encode(m.Odom(t=r.clock.now() + 0.01, x=9.0, y=9.0, theta=0.0, v=0.0, omega=0.0)))
    r.nav.drain()
    assert r.nav.pairing is None and r.nav.machine.pose.x == 0.0
    r.nav.close()
