"""The localizer service on the in-memory bus with a manual clock."""
import math

import pytest

from zenav.common import codec, keys
from zenav.common import messages as m
from zenav.common.bus import MemoryBus
from zenav.common.clock import ManualClock
from zenav.common.config import Settings
from zenav.common.scenarios import scenario
from zenav.services.localizer.service import Localizer
from zenav.services.localizer.synthetic import drive_square



@pytest.fixture(scope="module")
def run():
    return drive_square(scenario("default"), 5, duration=12.0)


def make(**localizer):
    bus, clock = MemoryBus(), ManualClock()
    svc = Localizer(Settings.load(None, localizer=localizer), bus, clock)
    svc.start()
    return svc, bus, clock


def put(bus, suffix, msg):
    bus.publish(keys.key("r1", suffix), codec.encode(msg))


def got(bus, suffix):
    typ = keys.TOPICS[suffix]
    return [codec.decode(d, typ) for k, d in bus.published if k == keys.key("r1", suffix)]


def replay(svc, bus, clock, run, t_end, t_start=0.0, fixes=True):
    """The sensors as the stack delivers them: IMU then odometry each 10 ms, fixes on arrival."""
    for i, o in enumerate(run.odom):
        if not t_start <= o.t <= t_end:
            continue
        clock.t = o.t
        if fixes:
            for t_arr, f in run.fixes:
                if o.t - 0.01 < t_arr <= o.t:
                    put(bus, "vps/pose", f)
        put(bus, "sensors/imu", run.imu[i])
        put(bus, "odom", o)
        svc.drain()


def query(bus, svc, suffix, payload):
    q = bus.query(keys.key("r1", suffix), codec.encode(payload))
    svc.drain()
    [(ok, data)] = q.replies
    return ok, data


def test_publishes_a_map_pose_per_odom_sample_and_tracks_the_truth(run):
    svc, bus, clock = make()
    replay(svc, bus, clock, run, 12.0)
    poses = got(bus, "pose")
    assert len(poses) == len(run.odom) and [p.t for p in poses] == [o.t for o in run.odom]
    assert all(p.frame == "map" for p in poses)
    assert poses[0].cov[0] > 1.0  # before the first fix: odometry, position unknown
    errs = [math.hypot(p.x - tr.x, p.y - tr.y) for p, tr in zip(poses, run.truth) if p.t > 2.0]
    assert math.sqrt(sum(e * e for e in errs) / len(errs)) < 0.02
    assert poses[-1].calibration["track_width_scale"] > 1.0 and poses[-1].cov[0] < 1e-3
    assert any(p.correction != (0.0, 0.0, 0.0) for p in poses)
    svc.close()


def test_one_audit_record_per_fix_explaining_it(run):
    svc, bus, clock = make()
    replay(svc, bus, clock, run, 12.0)
    records = got(bus, "localizer/fixes")
    delivered = [f for t, f in run.fixes if t <= 12.0]
    assert [r.t for r in records] == [f.t for f in delivered]
    assert {r.reason for r in records} <= {"unconfirmed", "initialised", "accepted", "outlier"}
    for r in records:
        assert r.t_arrival >= r.t and r.latency == pytest.approx(r.t_arrival - r.t)
        assert r.accepted == (r.reason in ("initialised", "accepted"))
    assert sum(r.accepted for r in records) > 0.9 * len(records)
    assert max(r.replay_depth for r in records) >= 25  # 0.3 s late at 100 Hz
    c = svc.counters.values
    assert c["fixes_accepted"] == sum(r.reason == "accepted" for r in records)
    svc.close()


def test_queries_pose_and_set_pose_mid_drive(run):
    svc, bus, clock = make()
    ok, data = query(bus, svc, "localizer/pose", {})
    assert not ok and codec.decode(data, m.ErrorReply).error == "unavailable"
    replay(svc, bus, clock, run, 6.0)
    ok, data = query(bus, svc, "localizer/pose", {})
    rep = codec.decode(data, m.LocalizerPoseReply)
    assert ok and rep.t == 6.0 and rep.vps_latency == pytest.approx(0.3, abs=0.03)
    assert {"distance_scale", "track_width_scale", "wheel_radius_ratio", "gyro_bias"} <= set(rep.calibration)
    ok, data = query(bus, svc, "localizer/set_pose", {"x": 3.0, "y": 4.0})  # setPosition
    ps = codec.decode(data, m.PoseStamped)
    assert ok and (ps.x, ps.y, ps.t) == (3.0, 4.0, 6.0) and ps.theta == pytest.approx(rep.theta)
    replay(svc, bus, clock, run, 6.2, t_start=6.01)
    records = got(bus, "localizer/fixes")
    assert records[-1].reason == "before_set_pose"  # captured before the reset
    assert got(bus, "pose")[-1].x == pytest.approx(3.0 + run.truth[620].x - run.truth[600].x, abs=0.01)
    ok, data = query(bus, svc, "localizer/set_pose", {"x": 1.0, "tolerence": 1})
    assert not ok and "tolerence" in codec.decode(data, m.ErrorReply).message
    svc.close()


def test_diag_degraded_without_fixes_and_reports_latency(run):
    svc, bus, clock = make(expected_latency=0.5)
    replay(svc, bus, clock, run, 2.0, fixes=False)
    d = got(bus, "diag/localizer")[-1]
    assert d.status == "degraded" and "no VPS fix" in d.message
    replay(svc, bus, clock, run, 6.0, t_start=2.01)
    d = got(bus, "diag/localizer")[-1]
    assert d.status == "ok" and "vps latency 0.3" in d.message and "expected 0.500" in d.message
    replay(svc, bus, clock, run, 10.5, t_start=6.01, fixes=False)  # the camera goes quiet
    d = got(bus, "diag/localizer")[-1]
    assert d.status == "degraded" and "no VPS fix accepted for" in d.message
    svc.close()


def test_stale_odometry_is_counted_and_dropped():
    svc, bus, clock = make()
    put(bus, "odom", m.Odom(t=1.0, x=0.0, y=0.0, theta=0.0, v=0.0, omega=0.0))
    put(bus, "odom", m.Odom(t=0.5, x=0.0, y=0.0, theta=0.0, v=0.0, omega=0.0))
    svc.drain()
    assert len(got(bus, "pose")) == 1 and svc.counters.values["dropped_stale"] == 1
    svc.close()


@pytest.mark.parametrize("mode", ["dead_reckoning", "overwrite", "multisensor"])
def test_other_modes_by_config(mode, run):
    svc, bus, clock = make(mode=mode)
    replay(svc, bus, clock, run, 3.0)
    assert len(got(bus, "pose")) == 301 and len(got(bus, "localizer/fixes")) > 0
    svc.close()




def test_a_sim_restart_starts_the_estimate_again(run):
    from zenav.common.clock import SimClock

    bus, clock = MemoryBus(), SimClock()
    svc = Localizer(Settings.load(None), bus, clock)
    svc.start()
    put(bus, "clock", m.Clock(t=20.0, wall=0.0))
    for i, o in enumerate(run.odom[:50]):  # odom of the old world, at t = 20 s and after
        put(bus, "odom", m.Odom(t=20.0 + o.t, x=o.x, y=o.y, theta=o.theta, v=o.v, omega=o.omega))
    svc.drain()
    before = len(got(bus, "pose"))
    put(bus, "clock", m.Clock(t=0.01, wall=0.0))  # the sim restarted
    put(bus, "odom", m.Odom(t=0.01, x=0.0, y=0.0, theta=0.0, v=0.0, omega=0.0))
    svc.drain()
    poses = got(bus, "pose")
    assert len(poses) == before + 1 and poses[-1].t == 0.01
    assert svc.counters.values["clock_resets"] == 1
    svc.close()
