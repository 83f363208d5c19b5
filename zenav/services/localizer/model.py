"""The EKF's motion and measurement model, as pure functions.

State (map frame): x [m], y [m], theta [rad]; the odometry's calibration errors
relative to the nominal geometry: es (distance scale: mean wheel radius), ew (track
width), ed (half the right-minus-left wheel radius difference); the gyro's bias
bg [rad/s] and scale error sg; and ro [rad], the tick rounding in the odometry's
heading where it was last compared with the gyro's.

Input: one odom increment (ds [m] forward, dth [rad]) computed with the nominal
geometry, over dt [s], and optionally the gyro's integral over the same span. When
the gyro is there, it steers the heading, and the odometry's heading increment is a
measurement of the calibration states: that is how the track width is learnt. The
counts are cumulative, so their rounding does not add up from increment to increment:
each increment's rounding at its end is the next one's at its start (ro), and over a
turn the rounding stays one tick while the turned angle grows.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from zenav.common.geometry import wrap_angle

# Squared sigmas: an odometry heading step further than this from the gyro's is not
# the wheels' doing (an odometry that resets its heading from a compass, a glitch).
ODOM_GATE = 25.0
N = 9  # state size
X, Y, TH, ES, EW, ED, BG, SG, RO = range(N)
POSE = slice(0, 3)
Vec = list[float]  # the state
Mat = list[list[float]]  # its covariance, row by row


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


def rounding_var(nz: Noise) -> float:
    """[rad^2] the variance of the tick rounding in the odometry's heading at one time: each wheel's count
    is its travel rounded down to a tick (uniform: tick^2 / 12), the heading their difference over the track.
    Kept whole with the odometry's sub-tick estimate too: a smaller rounding made the pose less accurate."""
    return nz.tick**2 / (6.0 * nz.track**2)


def _wheel_vars(u: Step, nz: Noise) -> tuple[float, float]:
    """(slip variance of each wheel [m^2] summed, their difference)."""
    dl, dr = abs(u.ds - nz.track * u.dth / 2.0), abs(u.ds + nz.track * u.dth / 2.0)
    var_l, var_r = nz.wheel_var * dl + u.unmeasured[0], nz.wheel_var * dr + u.unmeasured[1]
    return var_l + var_r, var_r - var_l


# The steps run on Python floats: deployed, each odom sample finds the localizer's process
# cold (it sat idle while the others ran), and there numpy's calls cost many times a float
# loop's, while back to back the two are about even (docs/benchmarks.md). The pose fixes,
# ten times fewer and off the control chain, use numpy.


def _fresh_rounding(s: Vec, P: Mat, nz: Noise) -> tuple[Vec, Mat]:
    """(state, covariance) with ro forgotten: the next comparison starts from a rounding nothing says yet."""
    vr = rounding_var(nz)
    if s[RO] == 0.0 and P[RO][RO] == vr and not any(row[RO] for row in P[:RO]):
        return s, P  # forgotten already (each step without the gyro): no copy
    out = [row[:] for row in P]
    for row in out:
        row[RO] = 0.0
    out[RO] = [0.0] * N
    out[RO][RO] = vr
    return [*s[:RO], 0.0], out


def _learn_from_gyro(s: Vec, P: Mat, u: Step, slip: float, nz: Noise) -> tuple[Vec, Mat]:
    """Update (state, covariance) with the odometry's heading increment, predicted from the gyro's (slip: the
    wheels' travel variance [m^2] over it).

    The odometry's increment is the true one plus the rounding at its end (a new state, ro_end) minus
    that at its start (ro). The update takes ro_end into the state and drops the start's: the rounding
    at each end is counted once, however many increments a turn is cut into, and the sample a count
    moves at says where the wheel is to a fraction of a tick. Weighing each increment's rounding
    afresh instead made the odometry's heading over a turn look many times noisier than it is, and the
    prior held the track width near the nominal (by 1.5 % on 16-tick encoders).
    """
    track = nz.track
    assert u.gyro is not None
    _, _, _, es, ew, ed, bg, sg, ro = s
    kg, ke, kw = 1.0 + sg, 1.0 + es, 1.0 + ew
    g = (u.gyro - bg * u.dt) / kg  # the gyro's change corrected by its bias and scale
    pred = (g * kw - 2.0 * ed * u.ds / track) / ke  # the odometry's dth, but for the rounding, if the state is right
    r = kw / ke
    # h = d(odometry's dth)/d(state): naught on the pose, -1 on ro; +1 on ro_end (prior: naught, vr, independent)
    h3, h4, h5, h6, h7 = -pred / ke, g / ke, -2.0 * u.ds / (track * ke), -u.dt / kg * r, -g / kg * r
    Ph = [p[3] * h3 + p[4] * h4 + p[5] * h5 + p[6] * h6 + p[7] * h7 - p[RO] for p in P]  # P is symmetric: h P = (P h)^T
    vr = rounding_var(nz)
    S = Ph[3] * h3 + Ph[4] * h4 + Ph[5] * h5 + Ph[6] * h6 + Ph[7] * h7 - Ph[RO] + vr + slip / track**2 + nz.gyro_var * u.dt
    nu = u.dth - pred + ro
    if nu * nu > ODOM_GATE * S:  # not the wheels' doing: the odometry's heading was corrected
        return _fresh_rounding(s, P, nz)
    K = [p / S for p in Ph]
    k_end = vr / S  # ro_end's gain; its covariance with the rest after the update: -K vr
    out = [[p - k * q for p, q in zip(row[:RO], Ph[:RO])] + [-k * vr] for row, k in zip(P[:RO], K[:RO])]
    out.append([*(-k * vr for k in K[:RO]), vr - k_end * vr])
    return [*(a + k * nu for a, k in zip(s[:RO], K[:RO])), k_end * nu], out


def predict(s: Vec, P: Mat, u: Step, nz: Noise) -> tuple[Vec, Mat]:
    """Propagate (state, covariance) through one increment.

    Without the gyro, the calibrated odometry turns the heading; with it, the gyro
    does, and the odometry's heading increment teaches the calibration.
    """
    var_sum, var_diff = _wheel_vars(u, nz)
    track = nz.track
    s, P = _fresh_rounding(s, P, nz) if u.gyro is None else _learn_from_gyro(s, P, u, var_sum, nz)
    x, y, th, es, ew, ed, bg, sg, ro = s
    if u.gyro is None:  # the odometry's heading increment corrected by the calibration
        k = 1.0 + ew
        # Wheels: nominal travel dl, dr = ds -+ track*dth/2; true = nominal*(1 + es -+ ed).
        dth = (u.dth * (1.0 + es) + 2.0 * ed * u.ds / track) / k
        # J: d(dth)/d(state), (index, value) where it is not naught
        J: tuple[tuple[int, float], ...] = ((ES, u.dth / k), (EW, -dth / k), (ED, 2.0 * u.ds / (track * k)))
        kb = track * k
        var_dth, cov_ds_dth = var_sum / kb**2, var_diff / (2.0 * kb)
    else:  # the gyro's, corrected by its bias and scale
        k = 1.0 + sg
        dth = (u.gyro - bg * u.dt) / k
        J = ((BG, -u.dt / k), (SG, -dth / k))
        var_dth, cov_ds_dth = nz.gyro_var * u.dt, 0.0
    half = track * u.dth / 2.0
    ds_t = u.ds * (1.0 + es) + ed * half
    phi = th + dth / 2.0
    c, sn = math.cos(phi), math.sin(phi)
    # F is the identity but for its pose rows A = d(x, y, theta)/d(state): F P F^T differs from P only in
    # the pose rows and columns. A's rows: those of x, y and theta, plus these times theirs and J.
    ax, ay = -ds_t * sn / 2.0, ds_t * c / 2.0  # d(x, y)/d(dth)
    kx, ky = -ds_t * sn, ds_t * c  # d(x, y)/d(theta)
    ex, ey = u.ds * c, u.ds * sn  # d(x, y)/d(es)
    hx, hy = half * c, half * sn  # d(x, y)/d(ed)

    def along(v: Vec) -> tuple[float, float, float]:
        """A v, v a column of the state's size."""
        jv = sum(j * v[i] for i, j in J)
        return v[X] + ax * jv + kx * v[TH] + ex * v[ES] + hx * v[ED], v[Y] + ay * jv + ky * v[TH] + ey * v[ES] + hy * v[ED], v[TH] + jv

    (i0, j0), *more = J
    JP = [j0 * p for p in P[i0]]  # J P
    for i, j in more:
        JP = [a + j * p for a, p in zip(JP, P[i])]
    AP = (  # A P: `along` applied to each of P's columns, row by row
        [p + ax * q + kx * t + ex * e + hx * d for p, q, t, e, d in zip(P[X], JP, P[TH], P[ES], P[ED])],
        [p + ay * q + ky * t + ey * e + hy * d for p, q, t, e, d in zip(P[Y], JP, P[TH], P[ES], P[ED])],
        [t + q for t, q in zip(P[TH], JP)],
    )
    # Q: the increment's noise through G = d(x, y, theta)/d(ds, dth), and the random walks.
    vs, vd, cv = var_sum / 4.0, var_dth, cov_ds_dth
    g = ((c, ax), (sn, ay), (0.0, 1.0))
    M = [(a * vs + b * cv, a * cv + b * vd) for a, b in g]  # G M
    (qxx, qxy, qxt), (_, qyy, qyt), (_, _, qtt) = ([m0 * a + m1 * b for a, b in g] for m0, m1 in M)
    (pxx, pxy, pxt), (_, pyy, pyt), (_, _, ptt) = (along(row) for row in AP)  # A P A^T, symmetric
    out = [
        [pxx + qxx, pxy + qxy, pxt + qxt, *AP[0][3:]],
        [pxy + qxy, pyy + qyy, pyt + qyt, *AP[1][3:]],
        [pxt + qxt, pyt + qyt, ptt + qtt, *AP[2][3:]],
    ] + [[a, b, t, *row[3:]] for a, b, t, row in zip(AP[0][3:], AP[1][3:], AP[2][3:], P[3:])]
    walk = nz.calib_var * (abs(u.ds) + track * abs(u.dth) / 2.0)
    out[ES][ES] += walk
    out[EW][EW] += walk
    out[ED][ED] += walk
    out[BG][BG] += nz.bias_var * u.dt
    return [x + ds_t * c, y + ds_t * sn, wrap_angle(th + dth), es, ew, ed, bg, sg, ro], out


def rounding_cov(nz: Noise, theta: float, heading: bool) -> np.ndarray:
    """The 3x3 covariance of the odometry's pose rounded to whole ticks, at heading theta [rad].

    Each wheel's count is its travel rounded to a tick (uniform: variance tick^2 / 12). The
    counts are cumulative, so the rounding never accumulates (the prediction leaves it out),
    but the pose at any time is off by it: along the heading by the two wheels' mean, and,
    where the encoders turn the heading (`heading`: no gyro), by their difference over the
    track. A fix compares with that pose, so its covariance takes this on: without it, a
    camera finer than a tick found a fifth of its fixes outliers on sixteen-tick encoders.
    """
    v = nz.tick**2 / 12.0  # [m^2] each wheel's
    along = v / 2.0  # [m^2] the mean of the two
    c, s = math.cos(theta), math.sin(theta)
    R = np.zeros((3, 3))
    R[0, 0], R[0, 1], R[1, 1] = along * c * c, along * c * s, along * s * s
    R[1, 0] = R[0, 1]
    if heading:
        R[2, 2] = 2.0 * v / nz.track**2
    return R


def pose_cov(P: Mat) -> np.ndarray:
    """The 3x3 covariance of (x, y, theta)."""
    return np.array((P[0][:3], P[1][:3], P[2][:3]))


def innovation(s: Vec, P: Mat, z: np.ndarray, R: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """(innovation, its covariance S, squared Mahalanobis distance) of a pose fix z."""
    nu = z - np.array(s[:3])
    nu[2] = wrap_angle(nu[2])
    S = pose_cov(P) + R
    return nu, S, float(nu @ np.linalg.solve(S, nu))


def update(s: Vec, P: Mat, nu: np.ndarray, S: np.ndarray, R: np.ndarray) -> tuple[Vec, Mat]:
    """The EKF update with a pose fix (Joseph form, symmetric result)."""
    Pa = np.array(P)
    K = np.linalg.solve(S, Pa[POSE, :]).T  # P H^T S^-1, with S symmetric
    out = np.array(s) + K @ nu
    out[TH] = wrap_angle(out[TH])
    IKH = np.eye(N)
    IKH[:, POSE] -= K  # I - K H, H picking the pose
    P_new = IKH @ Pa @ IKH.T + K @ R @ K.T
    return out.tolist(), ((P_new + P_new.T) / 2.0).tolist()


def calibration(s: Vec, P: Mat, track: float, radius: float, gyro: bool) -> dict[str, float]:
    """The calibration estimates in user terms (true / nominal, and the geometry they give from the nominal
    track and wheel radius [m]), each scale's 1-sigma relative to it (`_sigma`); the gyro's once it has
    been used."""
    es, ew, ed = s[ES], s[EW], s[ED]
    ke, big = 1.0 + es, (1.0 + es + ed) ** 2
    je, jd = 2.0 * ed / big, -2.0 * ke / big  # d(wheel_radius_ratio)/d(es, ed)
    ratio_var = je * je * P[ES][ES] + 2.0 * je * jd * P[ES][ED] + jd * jd * P[ED][ED]
    ratio = (1.0 + es - ed) / (1.0 + es + ed)
    out = {
        "distance_scale_sigma": math.sqrt(P[ES][ES]) / ke,
        "track_width_scale_sigma": math.sqrt(P[EW][EW]) / (1.0 + ew),
        "wheel_radius_ratio_sigma": math.sqrt(ratio_var) / ratio,
        "distance_scale": 1.0 + es,  # true / nominal mean wheel radius
        "track_width_scale": 1.0 + ew,  # true / nominal track width
        "wheel_radius_ratio": ratio,  # left / right
        "track_width": track * (1.0 + ew),  # [m]
        "wheel_diameter": 2.0 * radius * (1.0 + es),  # [m] the mean of the two
        "wheel_radius_left": radius * (1.0 + es - ed),  # [m]
        "wheel_radius_right": radius * (1.0 + es + ed),  # [m]
    }
    if gyro:
        out["gyro_bias"] = s[BG]  # [rad/s]
        out["gyro_scale"] = 1.0 + s[SG]  # measured / true rate
    return out
