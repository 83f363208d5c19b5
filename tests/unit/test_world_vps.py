"""The VPS camera model: rate, noise, drops, outliers, outage, latency, seeding."""

import math

import numpy as np
import pytest

from zenav.common import messages as m
from zenav.common.scenarios import scenario
from zenav.world.vps import Camera, Delivery, DeliveryQueue, make_rng

CLEAN = {"vps_noise_xy": 0.0, "vps_noise_theta_deg": 0.0, "vps_drop": 0.0, "vps_outlier": 0.0, "vps_jitter": 0.0}


def truth_stream(duration: float, rate: float = 100.0, t0: float = 0.0):
    """A robot driving along x at 0.3 m/s, sampled at `rate`."""
    n = int(round(duration * rate))
    return [m.Truth(t=t0 + k / rate, x=0.3 * k / rate, y=1.0, theta=0.5, v=0.3, omega=0.0) for k in range(n)]


def captures(sc, seed=1, duration=10.0, **kw):
    cam = Camera(sc, make_rng(seed))
    return [d for tr in truth_stream(duration, **kw) if (d := cam.capture(tr)) is not None]


def test_rate_and_capture_stamp_without_errors():
    sc = scenario("default", CLEAN)
    out = captures(sc)
    assert len(out) == 100
    times = [d.fix.t for d in out]
    assert np.allclose(np.diff(times), 0.1)
    for d in out:  # a clean fix is the truth at its capture time, delivered exactly latency later
        assert d.fix.x == pytest.approx(0.3 * d.fix.t) and d.fix.y == 1.0 and d.fix.theta == 0.5
        assert d.t_delivery == pytest.approx(d.fix.t + 0.3)


def test_noise_statistics_and_covariance():
    sc = scenario("default", {"vps_drop": 0.0, "vps_outlier": 0.0})
    out = captures(sc, duration=200.0)
    ex = np.array([d.fix.x - 0.3 * d.fix.t for d in out])
    eth = np.array([d.fix.theta - 0.5 for d in out])
    assert abs(ex.mean()) < 0.004 and ex.std() == pytest.approx(0.02, rel=0.1)
    assert eth.std() == pytest.approx(math.radians(2.0), rel=0.1)
    cov = out[0].fix.cov
    assert cov[0] == cov[4] == pytest.approx(0.02**2) and cov[8] == pytest.approx(math.radians(2.0) ** 2)
    assert cov[1] == cov[3] == 0.0


def test_drops_and_outliers_at_their_rates():
    sc = scenario("default", {**CLEAN, "vps_drop": 0.2, "vps_outlier": 0.1})
    out = captures(sc, duration=500.0)
    assert len(out) / 5000 == pytest.approx(0.8, abs=0.03)
    outliers = [d for d in out if d.outlier]
    assert len(outliers) / len(out) == pytest.approx(0.1, abs=0.02)
    for d in outliers:  # displaced by exactly the outlier distance, in any direction
        assert math.hypot(d.fix.x - 0.3 * d.fix.t, d.fix.y - 1.0) == pytest.approx(0.5)
    angles = [math.atan2(d.fix.y - 1.0, d.fix.x - 0.3 * d.fix.t) for d in outliers]
    assert min(angles) < -2.0 and max(angles) > 2.0


def test_outage_loses_every_capture_in_it():
    sc = scenario("harsh", {**CLEAN})
    out = captures(sc, duration=40.0)
    times = [d.fix.t for d in out]
    assert not any(20.0 <= t < 30.0 for t in times)
    assert any(t < 20.0 for t in times) and any(t >= 30.0 for t in times)
    assert np.allclose(np.diff([t for t in times if t < 20.0]), 0.2)  # harsh: 5 Hz


def test_latency_with_jitter_stays_in_its_band():
    sc = scenario("harsh", {"vps_drop": 0.0})
    out = captures(sc, duration=100.0)
    lat = np.array([d.t_delivery - d.fix.t for d in out])
    assert lat.min() >= 0.4 - 1e-9 and lat.max() <= 0.6 + 1e-9
    assert lat.mean() == pytest.approx(0.5, abs=0.01) and lat.std() > 0.04


def test_seeded_streams_repeat_and_differ():
    sc = scenario("default")
    a, b, c = captures(sc, seed=3), captures(sc, seed=3), captures(sc, seed=4)
    assert [d.fix for d in a] == [d.fix for d in b]
    assert [d.fix for d in a] != [d.fix for d in c]


def test_time_going_back_restarts_the_schedule():
    sc = scenario("default", CLEAN)
    cam = Camera(sc, make_rng(1))
    first = [d for tr in truth_stream(5.0, t0=50.0) if (d := cam.capture(tr))]
    again = [d for tr in truth_stream(1.0) if (d := cam.capture(tr))]
    assert len(first) == 50 and [d.fix.t for d in again][:2] == pytest.approx([0.0, 0.1])


def test_queue_delivers_in_delivery_order_even_when_captured_otherwise():
    q = DeliveryQueue()
    fix = m.VpsPose(t=1.0, x=0.0, y=0.0, theta=0.0)
    q.push(Delivery(1.35, 1, fix))
    q.push(Delivery(1.30, 2, m.VpsPose(t=1.1, x=0.0, y=0.0, theta=0.0)))
    assert q.pop_due(1.29) == []
    assert [d.seq for d in q.pop_due(1.40)] == [2, 1]
    assert len(q) == 0
