"""The EKF's motion and measurement model, as pure functions on numpy arrays.

State (map frame): x [m], y [m], theta [rad]; the odometry's calibration errors
relative to the nominal geometry: es (distance scale: mean wheel radius), ew (track
width), ed (half the right-minus-left wheel radius difference); and the gyro's bias
bg [rad/s] and scale error sg.

Input: one odom increment (ds [m] forward, dth [rad]) computed with the nominal
geometry, over dt [s], and optionally the gyro's integral over the same span. When
the gyro is there, the two heading increments are fused by their variances and
their difference is a measurement of the calibration states (that is how the track
width is learnt while the gyro steers the heading).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from zenav.common.geometry import wrap_angle

# Squared sigmas: an odometry heading step further than this from the gyro's is not
# the wheels' doing (an odometry that resets its heading from a compass, a glitch).
ODOM_GATE = 25.0
N = 8  # state size
X, Y, TH, ES, EW, ED, BG, SG = range(N)
POSE = slice(0, 3)


@dataclass(frozen=True)
class Noise:
    """The filter's noise model."""

    track: float  # [m] nominal track width
    tick: float  # [m] wheel travel per encoder tick
    wheel_var: float  # [m^2/m] slip variance of each wheel's travel per metre it travels
    calib_var: float  # [1/m] random walk of each odometry calibration error per metre driven
    gyro_var: float  # [rad^2/s] angle random walk of the integrated gyro
    bias_var: float  # [rad^2/s^3] random walk of the gyro bias


@dataclass(frozen=True)
class Step:
    """One odom increment, with the gyro's integral over it when known."""

    ds: float  # [m] forward, nominal geometry
    dth: float  # [rad] nominal geometry
    dt: float  # [s]
    gyro: float | None = None  # [rad] raw gyro rate integrated over dt
    unmeasured: tuple[float, float] = (0.0, 0.0)  # [m^2] variance of each wheel's travel its silent encoder missed

    def part(self, f: float) -> Step:
        """The fraction f of this increment."""
        gyro = None if self.gyro is None else self.gyro * f
        return Step(self.ds * f, self.dth * f, self.dt * f, gyro, (self.unmeasured[0] * f, self.unmeasured[1] * f))


def _wheel_vars(u: Step, nz: Noise) -> tuple[float, float, float]:
    """(slip variance of each wheel [m^2] summed, their difference, and the tick rounding part)."""
    dl, dr = abs(u.ds - nz.track * u.dth / 2.0), abs(u.ds + nz.track * u.dth / 2.0)
    var_l, var_r = nz.wheel_var * dl + u.unmeasured[0], nz.wheel_var * dr + u.unmeasured[1]
    # Rounding to ticks does not accumulate (counts are cumulative): it only matters
    # when one increment is compared with the gyro's. A wheel may turn less than a
    # tick in a step and show nothing: the gyro says how far it went.
    if u.gyro is not None:
        dl, dr = max(dl, abs(u.ds - nz.track * u.gyro / 2.0)), max(dr, abs(u.ds + nz.track * u.gyro / 2.0))
    rounding = min(nz.tick * dl, nz.tick**2 / 6.0) + min(nz.tick * dr, nz.tick**2 / 6.0)
    return var_l + var_r, var_r - var_l, rounding


# The model works on the state as Python floats and on the covariance with as few numpy
# calls as the structure allows: one step changes only the pose rows of the Jacobian.


def _learn_from_gyro(s: np.ndarray, P: np.ndarray, u: Step, var_odom: float, nz: Noise) -> tuple[np.ndarray, np.ndarray]:
    """Update (state, covariance) with the odometry's heading increment, predicted from the gyro's.

    The gyro's is the far less noisy one; the other way round, tick rounding in the
    odometry's increment would bias the scale estimates.
    """
    assert u.gyro is not None
    _, _, _, es, ew, ed, bg, sg = s.tolist()
    kg, ke, kw = 1.0 + sg, 1.0 + es, 1.0 + ew
    g = (u.gyro - bg * u.dt) / kg  # the gyro's increment corrected by its bias and scale
    pred = (g * kw - 2.0 * ed * u.ds / nz.track) / ke  # the odometry's dth if the state is right
    r = kw / ke
    h = np.array((0.0, 0.0, 0.0, -pred / ke, g / ke, -2.0 * u.ds / (nz.track * ke), -u.dt / kg * r, -g / kg * r))
    Ph = P @ h  # P is symmetric: h P = (P h)^T
    S = float(h @ Ph) + var_odom + nz.gyro_var * u.dt
    nu = u.dth - pred
    if nu * nu > ODOM_GATE * S:  # not the wheels' doing: the odometry's heading was corrected
        return s, P
    K = Ph / S
    return s + K * nu, P - K[:, None] * Ph


def predict(s: np.ndarray, P: np.ndarray, u: Step, nz: Noise) -> tuple[np.ndarray, np.ndarray]:
    """Propagate (state, covariance) through one increment.

    Without the gyro, the calibrated odometry turns the heading; with it, the gyro
    does, and the odometry's heading increment teaches the calibration.
    """
    var_sum, var_diff, rounding = _wheel_vars(u, nz)
    track = nz.track
    if u.gyro is not None:
        s, P = _learn_from_gyro(s, P, u, (var_sum + rounding) / track**2, nz)
    x, y, th, es, ew, ed, bg, sg = s.tolist()
    J = [0.0] * N  # d(dth)/d(state)
    if u.gyro is None:  # the odometry's heading increment corrected by the calibration
        k = 1.0 + ew
        # Wheels: nominal travel dl, dr = ds -+ track*dth/2; true = nominal*(1 + es -+ ed).
        dth = (u.dth * (1.0 + es) + 2.0 * ed * u.ds / track) / k
        J[ES], J[EW], J[ED] = u.dth / k, -dth / k, 2.0 * u.ds / (track * k)
        kb = track * k
        var_dth, cov_ds_dth = var_sum / kb**2, var_diff / (2.0 * kb)
    else:  # the gyro's, corrected by its bias and scale
        k = 1.0 + sg
        dth = (u.gyro - bg * u.dt) / k
        J[BG], J[SG] = -u.dt / k, -dth / k
        var_dth, cov_ds_dth = nz.gyro_var * u.dt, 0.0
    half = track * u.dth / 2.0
    ds_t = u.ds * (1.0 + es) + ed * half
    phi = th + dth / 2.0
    c, sn = math.cos(phi), math.sin(phi)
    ax, ay = -ds_t * sn / 2.0, ds_t * c / 2.0  # d(x, y)/d(dth)
    row_x = [ax * j for j in J]
    row_y = [ay * j for j in J]
    row_th = J[:]
    row_x[X] += 1.0
    row_x[TH] -= ds_t * sn
    row_x[ES] += u.ds * c
    row_x[ED] += half * c
    row_y[Y] += 1.0
    row_y[TH] += ds_t * c
    row_y[ES] += u.ds * sn
    row_y[ED] += half * sn
    row_th[TH] += 1.0
    A = np.array((row_x, row_y, row_th))  # the pose rows of F; the others are the identity's
    AP = A @ P
    out = P.copy()
    out[POSE] = AP
    out[3:, POSE] = AP[:, 3:].T
    # Q: the increment's noise through G = d(x, y, theta)/d(ds, dth), and the random walks.
    vs, vd, cv = var_sum / 4.0, var_dth, cov_ds_dth
    g = ((c, ax), (sn, ay), (0.0, 1.0))
    M = [(a * vs + b * cv, a * cv + b * vd) for a, b in g]  # G M
    Q = [[m0 * a + m1 * b for a, b in g] for m0, m1 in M]
    out[POSE, POSE] = AP @ A.T + np.array(Q)
    walk = nz.calib_var * (abs(u.ds) + track * abs(u.dth) / 2.0)
    out[ES, ES] += walk
    out[EW, EW] += walk
    out[ED, ED] += walk
    out[BG, BG] += nz.bias_var * u.dt
    state = np.array((x + ds_t * c, y + ds_t * sn, wrap_angle(th + dth), es, ew, ed, bg, sg))
    return state, out


def innovation(s: np.ndarray, P: np.ndarray, z: np.ndarray, R: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """(innovation, its covariance S, squared Mahalanobis distance) of a pose fix z."""
    nu = z - s[POSE]
    nu[2] = wrap_angle(nu[2])
    S = P[POSE, POSE] + R
    return nu, S, float(nu @ np.linalg.solve(S, nu))


def update(s: np.ndarray, P: np.ndarray, nu: np.ndarray, S: np.ndarray, R: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The EKF update with a pose fix (Joseph form, symmetric result)."""
    K = np.linalg.solve(S, P[POSE, :]).T  # P H^T S^-1, with S symmetric
    out = s + K @ nu
    out[TH] = wrap_angle(out[TH])
    IKH = np.eye(N)
    IKH[:, POSE] -= K  # I - K H, H picking the pose
    P_new = IKH @ P @ IKH.T + K @ R @ K.T
    return out, (P_new + P_new.T) / 2.0


def calibration(s: np.ndarray, track: float, gyro: bool) -> dict[str, float]:
    """The calibration estimates in user terms (true / nominal); the gyro's once it has been used."""
    es, ew, ed = float(s[ES]), float(s[EW]), float(s[ED])
    out = {
        "distance_scale": 1.0 + es,  # true / nominal mean wheel radius
        "track_width_scale": 1.0 + ew,  # true / nominal track width
        "wheel_radius_ratio": (1.0 + es - ed) / (1.0 + es + ed),  # left / right
        "track_width": track * (1.0 + ew),  # [m]
    }
    if gyro:
        out["gyro_bias"] = float(s[BG])  # [rad/s]
        out["gyro_scale"] = 1.0 + float(s[SG])  # measured / true rate
    return out
