"""The vps service on the in-memory bus with a manual clock."""

import pytest

from zenav.common import codec, keys
from zenav.common import messages as m
from zenav.common.bus import MemoryBus
from zenav.common.clock import ManualClock
from zenav.common.config import ConfigError, Settings
from zenav.services.vps.service import Vps

CLEAN = {"vps_noise_xy": 0.0, "vps_noise_theta_deg": 0.0, "vps_drop": 0.0, "vps_outlier": 0.0, "vps_jitter": 0.0}


def make(scenario=None, **sections):
    bus, clock = MemoryBus(), ManualClock()
    svc = Vps(Settings.load(None, scenario=scenario or {}, **sections), bus, clock)
    svc.start()
    return svc, bus, clock


def fixes(bus):
    return [codec.decode(d, m.VpsPose) for k, d in bus.published if k == keys.key("r1", "vps/pose")]


def drive(svc, bus, clock, t_from: float, t_to: float, x0: float = 0.0):
    """Truth at 100 Hz on the stack clock, the service running between samples."""
    for k in range(int(round((t_to - t_from) * 100))):
        clock.t = t_from + k * 0.01
        truth = m.Truth(t=clock.t, x=x0 + 0.3 * clock.t, y=0.0, theta=0.0, v=0.3, omega=0.0)
        bus.publish(keys.key("r1", "sim/truth"), codec.encode(truth))
        svc.drain()


def test_fixes_arrive_after_the_latency_stamped_with_capture_time():
    svc, bus, clock = make(CLEAN)
    drive(svc, bus, clock, 0.0, 0.29)
    assert fixes(bus) == []  # the first capture (t = 0) is due at 0.3
    drive(svc, bus, clock, 0.29, 1.0)
    out = fixes(bus)
    assert [f.t for f in out] == pytest.approx([0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6])
    assert all(f.x == pytest.approx(0.3 * f.t) for f in out)
    assert out[0].cov[0] == 0.0  # noise-free camera: zero variance
    svc.close()


def test_covariance_is_the_noise_and_counters_show_captures():
    svc, bus, clock = make({"vps_drop": 0.0})
    drive(svc, bus, clock, 0.0, 2.0)
    out = fixes(bus)
    assert len(out) == 17 and out[0].cov[0] == pytest.approx(0.02**2)
    assert svc.counters.values["fixes_captured"] == 20
    svc.close()


def test_a_restarted_sim_voids_pending_fixes():
    svc, bus, clock = make(CLEAN)
    drive(svc, bus, clock, 2.0, 2.25, x0=100.0)  # three captures pending when time restarts
    drive(svc, bus, clock, 0.0, 2.5)
    out = fixes(bus)
    assert [f.t for f in out][:3] == pytest.approx([0.0, 0.1, 0.2]) and len(out) == 22
    assert all(f.x < 50.0 for f in out) and svc.counters.values["truth_restarts"] == 1
    svc.close()


def test_bad_config_fails_with_the_key_named():
    with pytest.raises(ConfigError, match="delivery_period"):
        make(vps={"delivery_period": 0.0})
