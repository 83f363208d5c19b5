"""The odometry service on the in-memory bus with a manual clock."""

import math

import pytest

from tests.support.rig import Rig
from zenav.common import messages as m
from zenav.common.app import main
from zenav.common.bus import MemoryBus
from zenav.common.clock import ManualClock, SimClock
from zenav.common.config import ConfigError, Settings
from zenav.services.odometry.service import Odometry

R, L, TPR = 0.0673 / 2.0, 0.1156, 360
DT = 0.01


def make(clock=None, **odometry):
    return Rig(Odometry, clock=clock, odometry=odometry)


def diag(rig):
    rig.advance(1.0)
    return rig.got("diag/odometry")[-1]


def ticks(angle):
    return math.floor(angle / (2.0 * math.pi) * TPR)


def drive(rig, seconds, v, omega, gyro_bias=0.0, compass_offset=None, imu=True, start=(0.0, 0.0, 0.0)):
    """Publish encoder (and IMU, compass) samples of a constant (v, omega); returns the wheel angles."""
    al, ar, heading = start
    wl, wr = (v - omega * L / 2) / R, (v + omega * L / 2) / R
    for _ in range(round(seconds / DT)):
        t = rig.clock.advance(DT)
        al, ar, heading = al + wl * DT, ar + wr * DT, heading + omega * DT
        if imu:
            rig.put("sensors/imu", m.Imu(t=t, gyro_z=omega + gyro_bias, accel_x=0.0, accel_y=v * omega))
        if compass_offset is not None and round(t / DT) % 10 == 0:
            rig.put("sensors/compass", m.Compass(t=t, heading=heading + compass_offset))
        rig.put("sensors/encoders", m.Encoders(t=t, left=ticks(al), right=ticks(ar)))
    return al, ar, heading


def test_one_odom_per_encoder_sample_with_its_t():
    rig = make(heading_source="encoders")
    drive(rig, 1.0, 0.2, 0.0)
    out = rig.got("odom")
    assert len(out) == 99  # the first sample is the baseline
    assert [o.t for o in out] == pytest.approx([(i + 2) * DT for i in range(99)])
    assert all(o.frame == "odom" and len(o.cov) == 9 for o in out)
    assert out[-1].x == pytest.approx(0.198, abs=0.002) and out[-1].v == pytest.approx(0.2, abs=0.1)


def test_only_the_heading_source_topics_are_subscribed():
    for source, expect_in in (("encoders", 100), ("gyro", 200), ("compass", 110)):
        rig = make(heading_source=source)
        drive(rig, 1.0, 0.2, 0.0, compass_offset=0.0)
        assert rig.svc.counters.values["msgs_in"] == expect_in, source
        rig.close()


def frozen_left(rig, seconds, cmd):
    """Encoder samples of a wheel pair commanded `cmd` [rad/s] whose left count holds still."""
    for _ in range(round(seconds / DT)):
        t = rig.clock.advance(DT)
        rig.put("sensors/encoders", m.Encoders(t=t, left=0, right=ticks(cmd[1] * t), cmd_left=cmd[0], cmd_right=cmd[1]))


def test_a_wheel_its_samples_say_was_commanded_whose_count_holds_is_silent():
    rig = make(heading_source="encoders")
    frozen_left(rig, 1.0, (5.0, 5.0))
    svc = rig.svc
    assert svc.status == "degraded" and "left encoder silent while commanded" in svc.status_message
    assert svc.counters.values["encoder_silent"] == 1
    last = rig.got("odom")[-1]
    assert last.unmeasured_left == pytest.approx(5.0 * DT * R) and last.unmeasured_right == 0.0


def test_the_commands_come_with_the_samples_not_from_motors_wheels():
    rig = make(heading_source="encoders")
    rig.put("motors/wheels", m.Wheels(t=0.0, left=5.0, right=5.0))  # not read: the samples below say nothing was commanded
    frozen_left(rig, 1.0, (0.0, 0.0))
    svc = rig.svc
    assert svc.status == "ok" and svc.counters.values.get("encoder_silent", 0) == 0
    assert svc.counters.values["msgs_in"] == 100  # the encoder samples only


def test_duplicate_and_out_of_order_samples_are_counted_stale():
    rig = make(heading_source="encoders")
    drive(rig, 0.5, 0.2, 0.0)
    n = len(rig.got("odom"))
    rig.put("sensors/encoders", m.Encoders(t=rig.t, left=999, right=999))
    rig.put("sensors/encoders", m.Encoders(t=rig.t - 0.2, left=0, right=0))
    assert len(rig.got("odom")) == n and rig.svc.counters.values["dropped_stale"] == 2


def test_encoder_reset_rebaselines_and_is_counted():
    rig = make(heading_source="encoders")
    drive(rig, 0.5, 0.2, 0.0)
    x = rig.got("odom")[-1].x
    rig.put("sensors/encoders", m.Encoders(t=rig.clock.advance(DT), left=0, right=0))  # the counters restarted
    rig.put("sensors/encoders", m.Encoders(t=rig.clock.advance(DT), left=2, right=2))
    assert rig.svc.counters.values["encoder_resets"] == 1
    assert rig.got("odom")[-1].x == pytest.approx(x + 2 * math.pi * 2 * R / TPR)


def test_gyro_source_with_bias_learnt_at_rest():
    rig = make(heading_source="gyro")
    bias = math.radians(0.5)
    drive(rig, 1.0, 0.0, 0.0, gyro_bias=bias)
    drive(rig, math.pi, 0.0, 0.5, gyro_bias=bias)
    # 314 samples of 0.5 rad/s; the trapezoid rule lags half a sample while the rate steps up
    assert rig.got("odom")[-1].theta == pytest.approx(0.5 * 3.14 - 0.5 * 0.5 * DT, abs=1e-6)
    assert diag(rig).status == "ok"


def test_gyro_silent_degrades_to_encoders():
    rig = make(heading_source="gyro")
    drive(rig, 0.5, 0.2, 0.0)
    drive(rig, 1.0, 0.2, 0.3, imu=False, start=(0.5 * 0.2 / R, 0.5 * 0.2 / R, 0.0))
    assert rig.svc.counters.values["heading_fallback"] > 0
    d = diag(rig)
    assert d.status == "degraded" and "gyro" in d.message
    # the last rate (0) is held for imu_timeout = 0.1 s, then the encoders' heading: 0.9 x 0.3 rad
    assert rig.got("odom")[-1].theta == pytest.approx(0.27, abs=0.01)


def test_compass_source_at_full_gain_is_absolute_in_the_odom_frame():
    rig = make(heading_source="compass", compass_gain=1.0)
    drive(rig, 1.0, 0.0, 0.0, compass_offset=2.0)  # the robot faces 2 rad in the map
    drive(rig, 2.0, 0.1, 0.4, compass_offset=2.0)
    o = rig.got("odom")[-1]
    assert rig.svc.state.compass.offset == pytest.approx(2.0)
    assert o.theta == pytest.approx(0.8, abs=1e-6)  # the latest compass sample is exact at t
    assert o.cov[8] == pytest.approx(0.05**2, rel=0.01)


def test_sim_restart_starts_a_new_baseline():
    rig = make(SimClock(), heading_source="encoders")
    rig.put("clock", m.Clock(t=50.0))
    for i in range(5):
        rig.put("sensors/encoders", m.Encoders(t=50.0 + i * DT, left=100 * i, right=100 * i))
    rig.put("clock", m.Clock(t=0.01, instance="sim-2"))  # a new sim instance: it restarted: time and counters start again
    for i in range(1, 4):
        rig.put("sensors/encoders", m.Encoders(t=i * DT, left=i, right=i))
    last, tick = rig.got("odom")[-1], 2 * math.pi * R / TPR  # [m] one tick's travel
    assert last.t == pytest.approx(0.03)
    assert 2 * tick <= last.x < 3 * tick  # the 2 ticks since the new baseline, and where it is within the third (sub-tick)
    assert rig.svc.counters.values["dropped_stale"] == 0
    rig.close()


@pytest.mark.parametrize("key, value", [("integrator", "rk5"), ("heading_source", "sun"), ("noise_k_left", -1.0)])
def test_bad_config_names_the_key(key, value):
    with pytest.raises(ConfigError, match=key):
        Odometry(Settings.load(None, odometry={key: value}), MemoryBus(), ManualClock())


def test_help(capsys):
    with pytest.raises(SystemExit) as e:
        main(Odometry, ["--help"])
    assert e.value.code == 0 and "zenav-odometry" in capsys.readouterr().out


def test_silent_encoders_are_an_error_until_the_next_sample():
    rig = make(heading_source="encoders")
    assert diag(rig).status == "ok"  # nothing heard yet: nothing is silent
    drive(rig, 0.5, 0.2, 0.0, imu=False)
    rig.advance(1.5)  # the encoder stream stops
    d = diag(rig)
    assert d.status == "error" and "no encoder sample for" in d.message
    drive(rig, 0.1, 0.2, 0.0, imu=False, start=(0.5 * 0.2 / R, 0.5 * 0.2 / R, 0.0))
    assert diag(rig).status == "ok"
