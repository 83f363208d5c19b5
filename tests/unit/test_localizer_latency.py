"""The VPS latency estimated online from the fixes and the odometry (fixes without capture stamps)."""

from __future__ import annotations

import math

import msgspec
import numpy as np
import pytest

from zenav.common import messages as m
from zenav.common.config import RobotConfig
from zenav.services.localizer.base import LocalizerConfig
from zenav.services.localizer.latency import LatencyEstimator, LatencyParams
from zenav.services.localizer.modes import make_mode

RATE, FIX_RATE = 100, 10  # [Hz]
PARAMS = LatencyParams(prior=0.3, prior_sigma=0.1, max_lag=1.0, step=0.01, window=4.0, sigma_xy=0.02, sigma_theta=0.035, max_odom_step=0.2)
ROT, SHIFT = 0.3, (2.0, -1.0)  # map pose of the odom frame: [rad], [m]


def square_path(seconds: float, turn: bool = True) -> list[tuple[float, float, float, float]]:
    """Odom poses (t, x, y, theta) at RATE: 1 m sides at 0.3 m/s, turning in place at 1.5 rad/s between them."""
    out, x, y, th = [], 0.0, 0.0, 0.0
    side, turning = 0.0, False
    for i in range(round(seconds * RATE)):
        out.append((i / RATE, x, y, th))
        if turning:
            step = min(1.5 / RATE, math.pi / 2 - side)
            th, side = th + step, side + step
            if side >= math.pi / 2 - 1e-9:
                turning, side = False, 0.0
        else:
            x, y, side = x + 0.3 / RATE * math.cos(th), y + 0.3 / RATE * math.sin(th), side + 0.3 / RATE
            if turn and side >= 1.0:
                turning, side = True, 0.0
    return out


def to_map(x: float, y: float, th: float) -> tuple[float, float, float]:
    c, s = math.cos(ROT), math.sin(ROT)
    return SHIFT[0] + c * x - s * y, SHIFT[1] + s * x + c * y, th + ROT


def run(path, latency: float, seed: int = 1) -> tuple[LatencyEstimator, list[tuple[float, float]]]:
    """The estimator fed the path and fixes captured every 1 / FIX_RATE s, arriving `latency` s later."""
    rng = np.random.default_rng(seed)
    est, history = LatencyEstimator(PARAMS), []
    arrivals = {round((i / FIX_RATE + latency) * RATE): i * RATE // FIX_RATE for i in range(len(path) * FIX_RATE // RATE)}
    for k, (t, x, y, th) in enumerate(path):
        est.on_odom(t, x, y, th)
        if k in arrivals:
            _, cx, cy, cth = path[arrivals[k]]
            fx, fy, fth = to_map(cx, cy, cth)
            nx, ny, nth = rng.standard_normal(3)
            e = est.on_fix(t, fx + 0.02 * nx, fy + 0.02 * ny, fth + 0.035 * nth)
            history.append((t, e.latency))
    return est, history


def test_converges_to_the_latency_from_a_wrong_prior():
    est, history = run(square_path(30.0), latency=0.47)
    assert est.estimate.windows >= 3
    assert est.estimate.latency == pytest.approx(0.47, abs=0.01)
    assert 0.0 < est.estimate.sigma < 0.02
    settled = [t for t, e in history if abs(e - 0.47) > 0.02]
    assert max(settled) < 20.0  # within 20 ms for good after at most 20 s (five sides)


def test_straight_at_a_constant_speed_keeps_the_prior():
    est, _ = run(square_path(3.0, turn=False), latency=0.47)
    assert est.estimate == (0.3, 0.1, 0)


def test_outliers_drop_out_of_the_fit():
    est, _ = run(square_path(12.0), latency=0.2)
    clean = est.fit()
    for k in range(3):  # three fixes half a metre off
        est.fixes[-1 - 3 * k] = (est.fixes[-1 - 3 * k][0], est.fixes[-1 - 3 * k][1] + 0.5, *est.fixes[-1 - 3 * k][2:])
    fit = est.fit()
    assert clean is not None and fit is not None
    assert fit[0] == pytest.approx(clean[0], abs=0.005) and fit[0] == pytest.approx(0.2, abs=2 * clean[1])


def test_an_odometry_restart_starts_the_history_again():
    est = LatencyEstimator(PARAMS)
    est.on_odom(0.0, 0.0, 0.0, 0.0)
    est.on_odom(0.01, 5.0, 0.0, 0.0)
    assert list(est.odom) == [(0.01, 5.0, 0.0, 0.0)]


def test_the_mode_uses_and_reports_the_estimate():
    cfg = msgspec.convert({"mode": "ekf", "latency": "estimate", "expected_latency": 0.3}, LocalizerConfig)
    loc = make_mode(cfg, RobotConfig())
    path = square_path(16.0)
    latency = 0.45
    arrivals = {round((i / FIX_RATE + latency) * RATE): i * RATE // FIX_RATE for i in range(len(path) * FIX_RATE // RATE)}
    rec = None
    for k, (t, x, y, th) in enumerate(path):
        loc.on_odom(m.Odom(t=t, x=x, y=y, theta=math.remainder(th, 2 * math.pi), v=0.0, omega=0.0))
        if k in arrivals:
            _, cx, cy, cth = path[arrivals[k]]
            fx, fy, fth = to_map(cx, cy, cth)
            rec = loc.on_fix(m.VpsPose(t=t, x=fx, y=fy, theta=math.remainder(fth, 2 * math.pi)), t)  # stamped on arrival
    assert rec is not None and rec.latency_estimate is not None and rec.latency_sigma is not None
    assert rec.latency_estimate == pytest.approx(latency, abs=0.01) and rec.latency == pytest.approx(rec.latency_estimate)
    assert loc.latency == rec.latency_estimate
    p = loc.get_pose()
    tx, ty, _ = to_map(*path[-1][1:])
    assert p is not None and math.hypot(p.x - tx, p.y - ty) < 0.02


def test_stamped_fixes_carry_no_estimate():
    loc = make_mode(LocalizerConfig(), RobotConfig())
    loc.on_odom(m.Odom(t=1.0, x=0.0, y=0.0, theta=0.0, v=0.0, omega=0.0))
    rec = loc.on_fix(m.VpsPose(t=0.8, x=0.0, y=0.0, theta=0.0), 1.1)
    assert rec.latency_estimate is None and rec.latency_sigma is None and rec.latency == pytest.approx(0.3)
