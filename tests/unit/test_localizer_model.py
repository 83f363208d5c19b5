"""The EKF's pure model functions and the gyro integral."""

import math

import numpy as np
import pytest

from zenav.services.localizer import model
from zenav.services.localizer.gyro import GyroIntegral

TRACK = 0.1156
QUIET = model.Noise(TRACK, 0.0, 0.0, 0.0, 1e-12, 0.0)  # no process noise


def state(theta=0.3, es=0.01, ew=0.02, ed=-0.003, bg=0.0, sg=0.0, ro=0.0):
    return [1.0, 2.0, theta, es, ew, ed, bg, sg, ro]


def zeros():
    return [[0.0] * model.N for _ in range(model.N)]


def test_odometry_increment_is_corrected_by_the_calibration():
    s = state(theta=0.0, es=0.01, ew=0.02, ed=0.0)
    out, _ = model.predict(s, zeros(), model.Step(0.1, 0.2, 0.1), QUIET)
    assert out[model.TH] == pytest.approx(0.2 * 1.01 / 1.02)
    dth = 0.2 * 1.01 / 1.02
    assert out[model.X] == pytest.approx(1.0 + 0.101 * math.cos(dth / 2))
    assert out[model.Y] == pytest.approx(2.0 + 0.101 * math.sin(dth / 2))


def jacobian(s: list[float], u: model.Step, nz: model.Noise, eps: float = 1e-6) -> np.ndarray:
    """F = d(predicted state)/d(state), by central differences of the state the step predicts."""
    J = np.zeros((model.N, model.N))
    for i in range(model.N):
        d = np.zeros(model.N)
        d[i] = eps
        ahead, behind = (model.predict((np.array(s) + k * d).tolist(), zeros(), u, nz)[0] for k in (1.0, -1.0))
        J[:, i] = (np.array(ahead) - np.array(behind)) / (2 * eps)
    return J


def test_transition_jacobian_matches_finite_differences():
    s, u = state(), model.Step(0.05, 0.1, 0.1)
    J = jacobian(s, u, QUIET)
    for i in range(model.N):  # P = e_i e_i^T  ->  F P F^T = F[:, i] F[:, i]^T
        P = zeros()
        P[i][i] = 1.0
        _, P_new = model.predict(s, P, u, QUIET)
        assert np.allclose(P_new, np.outer(J[:, i], J[:, i]), atol=1e-6)


def test_the_step_keeps_the_covariance_symmetric_and_equal_to_f_p_ft_plus_q():
    rng = np.random.default_rng(3)
    B = rng.normal(size=(model.N, model.N))
    P = B @ B.T * 1e-3
    nz = model.Noise(TRACK, 0.0, 1e-6, 1e-8, 1e-6, 1e-10)
    s, u = state(), model.Step(0.05, 0.1, 0.1)  # no gyro: the step is F P F^T + Q alone
    _, P_new = model.predict(s, P.tolist(), u, nz)
    _, from_zero = model.predict(s, zeros(), u, nz)  # Q
    J = jacobian(s, u, nz)
    assert P_new == np.array(P_new).T.tolist()  # exactly
    assert np.allclose(P_new, J @ P @ J.T + np.array(from_zero), atol=1e-9)


def test_gyro_steers_the_heading_and_standing_still_reveals_its_bias():
    nz = model.Noise(TRACK, 2 * math.pi * 0.03365 / 360, 1e-6, 0.0, 1e-6, 0.0)
    s = [0.0] * model.N
    P = np.diag([0.0, 0.0, 0.0, 0.05**2, 0.05**2, 0.05**2, 0.05**2, 0.05**2, model.rounding_var(nz)]).tolist()
    # 10 s still: the wheels show nothing, the gyro reads its bias. Each still step is weighed as any other (its counts
    # may hide up to a tick of travel), so the bias comes in over seconds, not at once.
    for _ in range(1000):
        s, P = model.predict(s, P, model.Step(0.0, 0.0, 0.01, 0.01 * 0.01), nz)
    assert s[model.BG] == pytest.approx(0.01, rel=0.05)
    s2, _ = model.predict(s, P, model.Step(0.0, 0.0, 0.01, 0.01 * 0.01), nz)
    assert abs(s2[model.TH] - s[model.TH]) < 1e-5  # the bias no longer turns the estimate


def test_update_pulls_to_the_fix_and_shrinks_the_covariance():
    s, P = state(theta=3.1), (np.eye(model.N) * 0.01).tolist()
    R = np.diag([1e-4, 1e-4, 1e-3])
    nu, S, d2 = model.innovation(s, P, np.array([1.1, 2.0, -3.1]), R)
    assert nu[2] == pytest.approx(2 * math.pi - 6.2)  # wrapped, not -6.2
    assert d2 == pytest.approx(nu @ np.linalg.solve(S, nu))
    out, P_new = model.update(s, P, nu, S, R)
    assert 1.0 < out[model.X] < 1.1 and P_new[0][0] < P[0][0] and np.allclose(P_new, np.array(P_new).T)


def test_calibration_in_user_terms():
    P = np.diag([0.0, 0.0, 0.0, 1e-6, 4e-6, 1e-8, 0.0, 0.0, 0.0]).tolist()
    cal = model.calibration(state(es=0.01, ew=0.02, ed=-0.003), P, TRACK, 0.03, gyro=False)
    assert cal["distance_scale"] == pytest.approx(1.01) and cal["track_width_scale"] == pytest.approx(1.02)
    assert cal["wheel_radius_ratio"] == pytest.approx(1.013 / 1.007) and "gyro_bias" not in cal
    # the geometry a config takes: the track and the mean diameter, and each wheel's radius
    assert cal["track_width"] == pytest.approx(TRACK * 1.02) and cal["wheel_diameter"] == pytest.approx(0.06 * 1.01)
    assert (cal["wheel_radius_left"], cal["wheel_radius_right"]) == pytest.approx((0.03 * 1.013, 0.03 * 1.007))
    # how sure each scale is, relative to it: the ratio's from the radius difference's (ratio ~ 1 - 2 ed)
    assert cal["distance_scale_sigma"] == pytest.approx(0.001 / 1.01) and cal["track_width_scale_sigma"] == pytest.approx(0.002 / 1.02)
    assert cal["wheel_radius_ratio_sigma"] == pytest.approx(2e-4, rel=0.02)


def turn_on_coarse_encoders(rate: float, seconds: float) -> float:
    """The track width scale learnt turning in place at `rate` [rad/s] on 16-tick encoders whose true track is
    2 % wider than the nominal, steered by an exact gyro (the other calibrations known)."""
    tick = 2 * math.pi * 0.03365 / 16
    nz = model.Noise(TRACK, tick, wheel_var=0.0, calib_var=0.0, gyro_var=1e-8, bias_var=0.0)
    s = [0.0] * model.N
    P = np.diag([0.0, 0.0, 0.0, 0.0, 0.05**2, 0.05**2, 0.0, 0.0, model.rounding_var(nz)]).tolist()
    dt, half = 0.01, TRACK * 1.02 / 2  # [s], [m] the true half track
    counts = (0, 0)  # (left, right) [ticks]
    for k in range(1, round(seconds / dt) + 1):
        wheels = (-rate * k * dt * half, rate * k * dt * half)  # [m] each wheel's true travel so far
        new = (math.floor(wheels[0] / tick), math.floor(wheels[1] / tick))
        dl, dr = ((n - o) * tick for n, o in zip(new, counts))
        counts = new
        s, P = model.predict(s, P, model.Step((dl + dr) / 2, (dr - dl) / TRACK, dt, rate * dt), nz)
    return 1.0 + s[model.EW]


def test_coarse_encoders_teach_the_track_width_unbiased():
    """A tick is 6.5 degrees of heading on 16-tick encoders, and most increments show none: each increment's
    rounding weighed afresh held the learnt track width near the nominal; the rounding carried from one
    increment to the next (ro) finds it within 0.2 % in one turn, whatever the rate."""
    for rate in (0.8, 2.0):
        assert turn_on_coarse_encoders(rate, 2 * math.pi / rate) == pytest.approx(1.02, rel=0.002)


def test_gyro_integral_between_samples_and_gaps():
    g = GyroIntegral(keep=1.0, max_gap=0.1)
    for k in range(11):
        assert g.add(k / 100, 1.0)
    assert g.between(0.02, 0.05) == pytest.approx(0.03)
    assert g.between(0.025, 0.05) == pytest.approx(0.025)  # interpolated inside a sample
    assert g.between(0.05, 0.2) is None  # not covered yet
    assert not g.add(0.05, 1.0)  # not newer
    g.add(0.5, 1.0)  # after a silence: restarts from here
    assert g.between(0.05, 0.5) is None and g.newest == 0.5
