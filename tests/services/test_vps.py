"""The vps service on the in-memory bus with a manual clock."""

import pytest

from tests.support.rig import Rig
from zenav.common import messages as m
from zenav.common.config import ConfigError
from zenav.services.vps.service import Vps

CLEAN = {"vps_noise_xy": 0.0, "vps_noise_theta_deg": 0.0, "vps_drop": 0.0, "vps_outlier": 0.0, "vps_jitter": 0.0}


def make(scenario=None, **sections):
    return Rig(Vps, scenario=scenario or {}, **sections)


def drive(rig, t_from: float, t_to: float, x0: float = 0.0):
    """Truth at 100 Hz on the stack clock, the service running between samples."""
    for k in range(int(round((t_to - t_from) * 100))):
        rig.clock.t = t = t_from + k * 0.01
        rig.put("sim/truth", m.Truth(t=t, x=x0 + 0.3 * t, y=0.0, theta=0.0, v=0.3, omega=0.0))


def test_fixes_arrive_after_the_latency_stamped_with_capture_time():
    rig = make(CLEAN)
    drive(rig, 0.0, 0.29)
    assert rig.got("vps/pose") == []  # the first capture (t = 0) is due at 0.3
    drive(rig, 0.29, 1.0)
    out = rig.got("vps/pose")
    assert [f.t for f in out] == pytest.approx([0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6])
    assert all(f.x == pytest.approx(0.3 * f.t) for f in out)
    assert out[0].cov[0] == 0.0  # noise-free camera: zero variance
    rig.close()


def test_a_fix_is_sent_at_its_delivery_time():
    rig = make({**CLEAN, "vps_latency": 0.3037})
    drive(rig, 0.0, 0.01)  # captured at t = 0, due at 0.3037
    rig.clock.t = 0.3036
    rig.drain()
    assert rig.got("vps/pose") == []
    rig.clock.t = 0.3037  # not a polling period later
    rig.drain()
    assert [f.t for f in rig.got("vps/pose")] == [0.0]
    rig.close()


def test_covariance_is_the_noise_and_counters_show_captures():
    rig = make({"vps_drop": 0.0})
    drive(rig, 0.0, 2.0)
    out = rig.got("vps/pose")
    assert len(out) == 17 and out[0].cov[0] == pytest.approx(0.02**2)
    assert rig.svc.counters.values["fixes_captured"] == 20
    rig.close()


def test_a_restarted_sim_voids_pending_fixes():
    rig = make(CLEAN)
    drive(rig, 2.0, 2.25, x0=100.0)  # three captures pending when time restarts
    rig.svc.on_clock_reset()  # as the runtime does when a new sim instance owns the clock
    drive(rig, 0.0, 2.5)
    out = rig.got("vps/pose")
    assert [f.t for f in out][:3] == pytest.approx([0.0, 0.1, 0.2]) and len(out) == 22
    assert all(f.x < 50.0 for f in out) and rig.svc.counters.values["fixes_voided"] == 3
    rig.close()


def test_truth_stamped_far_behind_the_clock_is_dropped_not_a_restart():
    rig = make(CLEAN)
    drive(rig, 2.0, 2.25)  # three captures pending
    rig.put("sim/truth", m.Truth(t=0.0, x=100.0, y=0.0, theta=0.0, v=0.0, omega=0.0))  # a stray, 2 s behind
    drive(rig, 2.25, 2.6)
    out = rig.got("vps/pose")
    assert [f.t for f in out] == pytest.approx([2.0, 2.1, 2.2]) and all(f.x < 50.0 for f in out)
    assert rig.svc.counters.values["dropped_stale"] == 1
    rig.close()


def test_bad_config_fails_with_the_key_named():
    with pytest.raises(ConfigError, match="stamp"):
        make(vps={"stamp": "later"})


def test_scheduled_faults_act_on_the_fixes_captured_while_they_last():
    faults = [{"kind": "duplicate", "start": 0.0, "duration": 0.15}, {"kind": "future_stamp", "start": 0.2, "duration": 0.05}]
    rig = make({**CLEAN, "faults": faults})
    drive(rig, 0.0, 0.65)
    assert [f.t for f in rig.got("vps/pose")] == pytest.approx([0.0, 0.0, 0.1, 0.1, 1000.2, 0.3])
    rig.close()


def test_silent_truth_is_an_error_until_the_next_sample():
    rig = make(CLEAN)
    rig.advance(1.0)
    assert rig.svc.status == "ok"  # nothing heard yet: nothing is silent
    drive(rig, 1.0, 1.5)
    rig.advance(1.5)
    assert rig.svc.status == "error" and "no sim/truth sample for" in rig.svc.status_message
    drive(rig, 3.0, 3.5)
    rig.advance(0.5)
    assert rig.svc.status == "ok"
    rig.close()
