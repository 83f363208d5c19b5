"""move_to_pose, exits and chained paths through the navigator service (in-memory bus, manual clock)."""

import math

import pytest

from tests.support.navigator import reply
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
