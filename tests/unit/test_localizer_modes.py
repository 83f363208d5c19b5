"""The baseline modes (dead reckoning, overwrite, speed-weighted, complementary) and the scoring."""

import math

import pytest

from zenav.bench.studies.localizer import drive_square, evaluate
from zenav.common import messages as m
from zenav.common.config import ConfigError, RobotConfig, Settings
from zenav.common.scenarios import scenario
from zenav.services.localizer.base import MODES, LocalizerConfig
from zenav.services.localizer.modes import make_mode

ROBOT = RobotConfig(ticks_per_rev=360)


def mode(name: str, **cfg):
    return make_mode(LocalizerConfig(mode=name, **cfg), ROBOT)


def odom(t: float, x: float, y: float = 0.0, theta: float = 0.0, v: float = 0.0) -> m.Odom:
    return m.Odom(t=t, x=x, y=y, theta=theta, v=v, omega=0.0)


def fix(t: float, x: float, y: float = 0.0, theta: float = 0.0) -> m.VpsPose:
    return m.VpsPose(t=t, x=x, y=y, theta=theta)


@pytest.fixture(scope="module")
def run():
    return drive_square(scenario("default"), 3, duration=20.0)


@pytest.mark.parametrize("name", MODES)
def test_every_mode_runs_and_uses_the_fixes(name, run):
    s = evaluate(mode(name), run.odom, run.fixes, run.truth, run.imu, run.compass)
    assert s.fixes_accepted + s.fixes_rejected == len(run.fixes)
    dr = evaluate(mode("dead_reckoning"), run.odom, run.fixes, run.truth)
    if name != "dead_reckoning":
        assert s.fixes_accepted > 0.5 * len(run.fixes) and s.rmse < dr.rmse


def test_dead_reckoning_follows_odometry_from_the_pose_set():
    dr = mode("dead_reckoning")
    dr.on_odom(odom(0.0, 1.0, 1.0))
    assert dr.get_pose().x == 1.0  # map = odom until told otherwise
    assert dr.on_fix(fix(0.0, 5.0), 0.3).reason == "ignored"
    dr.set_pose(0.0, x=0.0, y=0.0, theta=math.pi / 2)
    dr.on_odom(odom(0.01, 1.1, 1.0))  # 0.1 m forward in the odom frame
    p = dr.get_pose()
    assert (p.x, p.y, p.theta) == pytest.approx((0.0, 0.1, math.pi / 2))
    assert p.cov[0] == pytest.approx((0.005 + 0.05 * 0.1) ** 2)  # set_pose sigma + growth over 0.1 m


def test_set_pose_before_any_odometry_applies_at_the_first_sample():
    dr = mode("dead_reckoning")
    dr.set_pose(0.0, x=2.0, y=3.0, theta=0.0)
    dr.on_odom(odom(0.0, 0.5, 0.5))
    p = dr.get_pose()
    assert (p.x, p.y) == (2.0, 3.0)


def test_overwrite_takes_the_fix_position_and_keeps_the_heading():
    o = mode("overwrite")
    o.on_odom(odom(0.0, 0.0, theta=0.2))
    rec = o.on_fix(fix(0.0, 1.0, 2.0, theta=1.0), 0.3)
    p = o.get_pose()
    assert rec.accepted and (p.x, p.y, p.theta) == pytest.approx((1.0, 2.0, 0.2))


def test_weighted_trusts_the_fix_less_at_speed():
    slow, fast = mode("speed_weighted"), mode("speed_weighted")
    slow.on_odom(odom(0.0, 0.0, v=0.0))
    fast.on_odom(odom(0.0, 0.0, v=0.3))
    slow.on_fix(fix(0.0, 1.0), 0.3)
    fast.on_fix(fix(0.0, 1.0), 0.3)
    top = ROBOT.max_wheel_speed * ROBOT.wheel_radius
    assert slow.get_pose().x == pytest.approx(1.0)
    assert fast.get_pose().x == pytest.approx(1.0 - 0.3 / top)


def test_speed_weighted_latency_carries_the_fix_along_the_path_since_capture():
    w = mode("speed_weighted_latency")
    for k in range(101):  # 1 s along x at 0.3 m/s, odometry 1 cm short of the truth
        t = k / 100
        w.on_odom(odom(t, 0.29 * t, v=0.0))  # v = 0: the fix is fully trusted
    w.on_fix(fix(0.7, 0.21), 1.0)  # the truth 0.3 s ago
    # fix + the 0.087 m odometry moved since 0.7 s
    assert w.get_pose().x == pytest.approx(0.21 + 0.29 * 0.3, abs=1e-9)


def test_speed_weighted_latency_drops_fixes_older_than_its_history():
    w = mode("speed_weighted_latency", history=0.5)
    for k in range(101):
        w.on_odom(odom(k / 100, 0.003 * k))
    assert w.on_fix(fix(0.2, 0.06), 1.0).reason == "too_old"


def test_complementary_pulls_heading_to_the_compass():
    ms = mode("complementary", complementary_compass_weight=0.5)
    ms.on_odom(odom(0.0, 0.0))
    ms.on_compass(m.Compass(t=0.0, heading=0.4))
    assert ms.get_pose().theta == pytest.approx(0.2)


def test_stale_odometry_and_jumps_are_not_integrated():
    dr = mode("dead_reckoning")
    dr.on_odom(odom(1.0, 0.0))
    assert dr.on_odom(odom(0.5, 0.1)) == "stale"
    assert dr.on_odom(odom(1.01, 5.0)) == "jump"  # odometry restarted elsewhere
    assert dr.on_odom(odom(1.02, 5.003)) is None
    assert dr.get_pose().x == pytest.approx(0.003)


def test_evaluate_scores_a_perfect_estimate_as_zero():
    truth = [m.Truth(t=k / 100, x=0.003 * k, y=0.0, theta=0.0, v=0.3, omega=0.0) for k in range(500)]
    odometry = [odom(s.t, s.x, v=0.3) for s in truth]
    fixes = [(s.t + 0.3, fix(s.t, s.x + (0.5 if k == 10 else 0.0))) for k, s in enumerate(truth[::10])]
    s = evaluate(mode("dead_reckoning"), odometry, fixes, truth, outage=(2.0, 3.0))
    assert s.rmse == pytest.approx(0.0, abs=1e-12) and s.max == pytest.approx(0.0, abs=1e-12)
    assert s.outage_end is None and s.fixes_rejected == len(fixes)  # dead reckoning uses none
    o = evaluate(mode("overwrite"), odometry, fixes, truth, outage=(2.0, 3.0))
    assert o.outliers_accepted == 1 and o.outage_end is not None


def test_config_names_a_bad_mode():
    with pytest.raises(ConfigError, match="mode"):
        Settings.load(None, localizer={"mode": "kalman"}).section("localizer", LocalizerConfig)
