"""The localizer service on the in-memory bus with a manual clock."""

import math

import pytest

from tests.support.rig import Rig
from zenav.bench.studies.localizer import drive_square
from zenav.common import messages as m
from zenav.common.clock import SimClock
from zenav.common.scenarios import scenario
from zenav.services.localizer.service import Localizer


@pytest.fixture(scope="module")
def run():
    return drive_square(scenario("default"), 5, duration=12.0)


def make(**localizer):
    return Rig(Localizer, localizer=localizer)


def replay(rig, run, t_end, t_start=0.0, fixes=True):
    """The sensors as the stack delivers them: IMU then odometry each 10 ms, fixes on arrival."""
    for i, o in enumerate(run.odom):
        if not t_start <= o.t <= t_end:
            continue
        rig.clock.t = o.t
        if fixes:
            for t_arr, f in run.fixes:
                if o.t - 0.01 < t_arr <= o.t:
                    rig.put("vps/pose", f)
        rig.put("sensors/imu", run.imu[i])
        rig.put("odom", o)


@pytest.mark.parametrize(
    "mode, read",
    [("ekf", {"sensors/imu"}), ("dead_reckoning", set()), ("complementary", {"sensors/imu", "sensors/compass"})],
)
def test_only_the_sensor_topics_its_mode_reads_are_taken(mode, read):
    rig = make(mode=mode)
    rig.put("sensors/imu", m.Imu(t=0.0, gyro_z=0.1, accel_x=0.0, accel_y=0.0))
    rig.put("sensors/compass", m.Compass(t=0.0, heading=0.1))
    rig.drain()
    assert set(rig.svc.counters.window) == read
    rig.close()


def test_publishes_a_map_pose_per_odom_sample_and_tracks_the_truth(run):
    rig = make()
    replay(rig, run, 12.0)
    poses = rig.got("pose")
    assert len(poses) == len(run.odom) and [p.t for p in poses] == [o.t for o in run.odom]
    assert all(p.frame == "map" for p in poses)
    assert poses[0].cov[0] > 1.0  # before the first fix: odometry, position unknown
    errs = [math.hypot(p.x - tr.x, p.y - tr.y) for p, tr in zip(poses, run.truth) if p.t > 2.0]
    assert math.sqrt(sum(e * e for e in errs) / len(errs)) < 0.02
    assert poses[-1].calibration["track_width_scale"] > 1.0 and poses[-1].cov[0] < 1e-3
    assert any(p.correction != (0.0, 0.0, 0.0) for p in poses)
    rig.close()


def test_one_audit_record_per_fix_explaining_it(run):
    rig = make()
    replay(rig, run, 12.0)
    records = rig.got("localizer/fixes")
    delivered = [f for t, f in run.fixes if t <= 12.0]
    assert [r.t for r in records] == [f.t for f in delivered]
    assert {r.reason for r in records} <= {"unconfirmed", "initialised", "accepted", "outlier"}
    for r in records:
        assert r.t_arrival >= r.t and r.latency == pytest.approx(r.t_arrival - r.t)
        assert r.accepted == (r.reason in ("initialised", "accepted"))
    assert sum(r.accepted for r in records) > 0.9 * len(records)
    assert max(r.replay_depth for r in records) >= 25  # 0.3 s late at 100 Hz
    c = rig.svc.counters.values
    assert c["fixes_accepted"] == sum(r.reason == "accepted" for r in records)
    rig.close()


def test_queries_pose_and_set_pose_mid_drive(run):
    rig = make()
    err = rig.reply(rig.query("localizer/pose", {}))
    assert isinstance(err, m.ErrorReply) and err.error == "unavailable"
    replay(rig, run, 6.0)
    rep = rig.reply(rig.query("localizer/pose", {}))
    assert isinstance(rep, m.LocalizerPoseReply) and rep.t == 6.0 and rep.vps_latency == pytest.approx(0.3, abs=0.03)
    assert {"distance_scale", "track_width_scale", "wheel_radius_ratio", "gyro_bias"} <= set(rep.calibration)
    ps = rig.reply(rig.query("localizer/set_pose", {"x": 3.0, "y": 4.0}))  # setPosition
    assert isinstance(ps, m.PoseStamped) and (ps.x, ps.y, ps.t) == (3.0, 4.0, 6.0) and ps.theta == pytest.approx(rep.theta)
    replay(rig, run, 6.2, t_start=6.01)
    records = rig.got("localizer/fixes")
    assert records[-1].reason == "before_set_pose"  # captured before the reset
    assert rig.got("pose")[-1].x == pytest.approx(3.0 + run.truth[620].x - run.truth[600].x, abs=0.01)
    err = rig.reply(rig.query("localizer/set_pose", {"x": 1.0, "tolerence": 1}))
    assert isinstance(err, m.ErrorReply) and "tolerence" in err.message
    rig.close()


def test_an_empty_set_pose_is_refused_and_keeps_the_estimate(run):
    rig = make()
    replay(rig, run, 3.0)
    before = rig.reply(rig.query("localizer/pose", {}))
    for payload, params in (({}, None), (None, None), ({"x": None, "y": None, "theta": None}, None)):
        err = rig.reply(rig.query("localizer/set_pose", payload, params))
        assert isinstance(err, m.ErrorReply) and err.error == "invalid_argument", err
        assert "x, y, theta: none given" in err.message, err
    after = rig.reply(rig.query("localizer/pose", {}))
    assert (after.x, after.y, after.theta, after.cov) == (before.x, before.y, before.theta, before.cov)
    replay(rig, run, 3.5, t_start=3.01)
    assert all(r.reason != "before_set_pose" for r in rig.got("localizer/fixes"))  # the fix history was kept
    rig.close()


def test_diag_degraded_without_fixes_and_reports_latency(run):
    rig = make(expected_latency=0.5)
    replay(rig, run, 2.0, fixes=False)
    d = rig.got("diag/localizer")[-1]
    assert d.status == "degraded" and "no VPS fix" in d.message
    replay(rig, run, 6.0, t_start=2.01)
    d = rig.got("diag/localizer")[-1]
    assert d.status == "ok" and "vps latency 0.3" in d.message and "expected 0.500" in d.message
    replay(rig, run, 10.5, t_start=6.01, fixes=False)  # the camera goes quiet
    d = rig.got("diag/localizer")[-1]
    assert d.status == "degraded" and "no VPS fix accepted for" in d.message
    rig.close()


def test_a_gyro_sample_after_its_odom_sample_is_counted_late_and_filled_in(run):
    """The ekf predicts the steps a late gyro sample covers again: the estimate ends as if it had come first."""
    on_time, late = make(), make()
    replay(on_time, run, 3.0, fixes=False)  # the gyro sample before its odom sample
    for imu, odom in zip(run.imu, run.odom):
        if odom.t <= 3.0:
            late.clock.t = odom.t
            late.put("odom", odom)
            late.put("sensors/imu", imu)
    n = len(late.got("pose"))
    assert n == 301 and late.svc.counters.values["gyro_late"] == n
    assert "gyro_late" not in on_time.svc.counters.values
    a, b = on_time.svc.mode.get_pose(), late.svc.mode.get_pose()
    assert a is not None and b is not None and a.t == b.t == 3.0
    assert (b.x, b.y, b.theta) == pytest.approx((a.x, a.y, a.theta), abs=1e-12)
    assert b.calibration == pytest.approx(a.calibration, abs=1e-12)
    on_time.close()
    late.close()


def test_stale_odometry_is_counted_and_dropped():
    rig = make()
    rig.put("odom", m.Odom(t=1.0, x=0.0, y=0.0, theta=0.0, v=0.0, omega=0.0))
    rig.put("odom", m.Odom(t=0.5, x=0.0, y=0.0, theta=0.0, v=0.0, omega=0.0))
    assert len(rig.got("pose")) == 1 and rig.svc.counters.values["dropped_stale"] == 1
    rig.close()


@pytest.mark.parametrize("mode", ["dead_reckoning", "overwrite", "complementary"])
def test_other_modes_by_config(mode, run):
    rig = make(mode=mode)
    replay(rig, run, 3.0)
    assert len(rig.got("pose")) == 301 and len(rig.got("localizer/fixes")) > 0
    rig.close()


def test_a_sim_restart_starts_the_estimate_again(run):
    rig = Rig(Localizer, clock=SimClock())
    rig.put("clock", m.Clock(t=20.0, wall=0.0))
    for o in run.odom[:50]:  # odom of the old world, at t = 20 s and after
        rig.put("odom", m.Odom(t=20.0 + o.t, x=o.x, y=o.y, theta=o.theta, v=o.v, omega=o.omega))
    before = len(rig.got("pose"))
    rig.put("clock", m.Clock(t=0.01, wall=0.0, instance="sim-2"))  # a new sim instance: it restarted
    rig.put("odom", m.Odom(t=0.01, x=0.0, y=0.0, theta=0.0, v=0.0, omega=0.0))
    poses = rig.got("pose")
    assert len(poses) == before + 1 and poses[-1].t == 0.01
    assert rig.svc.counters.values["clock_resets"] == 1
    rig.close()


def test_diag_error_while_the_odometry_is_silent(run):
    rig = make()
    replay(rig, run, 3.0)
    rig.clock.t = 4.5  # the odometry stops
    rig.advance(0.5)
    d = rig.got("diag/localizer")[-1]
    assert d.status == "error" and "no odometry for" in d.message
    replay(rig, run, 6.0, t_start=5.01)
    assert rig.got("diag/localizer")[-1].status != "error"
    rig.close()
