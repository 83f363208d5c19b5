"""The odometry state machine: encoder samples (and heading sensors) in, odom poses out.

Pure: `update(state, params, left, right, t, cmd)` returns the new state, the odom message
of the sample (None when the sample only sets a baseline or is dropped) and what
happened. Each wheel's travel is its count's change, plus (`subtick`) the change of its
estimated position within the tick (subtick.py). The covariance carries a per-wheel
noise model (variance of a wheel's travel = k * |travel|) and the heading source's
noise through the integrator's Jacobians.
"""

from __future__ import annotations

import math
from typing import NamedTuple

from zenav.common import messages as m
from zenav.common.config import RobotConfig
from zenav.services.odometry import heading as hd
from zenav.services.odometry import integrators, stall, subtick

# What a sample did (the service counts and logs these).
OK = "ok"  # an odom pose
FALLBACK = "fallback"  # an odom pose, but the heading source's sensor is missing
BASELINE = "baseline"  # the first sample: only sets the tick baseline
STALE = "stale"  # not newer than the previous sample: dropped
RESET = "reset"  # an impossible tick jump: the encoders were reset, new baseline


class Params(NamedTuple):
    """Geometry and noise model of the odometry."""

    metres_per_tick: float  # [m] wheel travel per encoder tick (nominal)
    track: float  # [m] nominal track width
    max_tick_rate: float  # [ticks/s] a wheel counting faster than this was reset
    integrator: integrators.Integrator
    k_left: float  # [m] variance of the left wheel's travel per metre travelled (m^2/m)
    k_right: float  # [m]
    heading: hd.HeadingParams
    stall: stall.StallParams  # when a commanded wheel's silent encoder counts as silent
    subtick: bool = True  # each wheel's position within its tick from the tick timing (subtick.py); False: whole ticks
    motor_lag: float = 0.05  # [s] the motors' time constant, the sub-tick estimate's wheel model


def make_params(
    robot: RobotConfig,
    integrator: str,
    k_left: float,
    k_right: float,
    reset_factor: float,
    heading: hd.HeadingParams,
    stall_limits: tuple[float, float, float],
    subtick: bool = True,
    motor_lag: float = 0.05,
) -> Params:
    """Params from the nominal robot; reset_factor times the max wheel speed is impossible;
    stall_limits: (stall_speed [rad/s], min_ticks, min_time [s]) of a silent encoder (stall.py)."""
    ticks = robot.ticks_per_rev
    if ticks is None:
        raise ValueError("the robot's ticks_per_rev is unknown (Settings takes it from the scenario)")
    return Params(
        metres_per_tick=math.pi * robot.wheel_diameter / ticks,
        track=robot.track_width,
        max_tick_rate=reset_factor * robot.max_wheel_speed * ticks / (2.0 * math.pi),
        integrator=integrators.INTEGRATORS[integrator],
        k_left=k_left,
        k_right=k_right,
        heading=heading,
        stall=stall.params(ticks, robot.wheel_radius, *stall_limits),
        subtick=subtick,
        motor_lag=motor_lag,
    )


class OdometryState(NamedTuple):
    """Everything the odometry remembers between samples."""

    t: float | None = None  # [s] newest encoder sample; None: no baseline yet
    t0: float = 0.0  # [s] first sample: heading sensors count as missing only from t0 + timeout
    left: int = 0  # [ticks] left count at t
    right: int = 0  # [ticks]
    t_moved: float = -math.inf  # [s] newest sample in which a wheel moved (the robot starts at rest)
    x: float = 0.0  # [m] odom frame
    y: float = 0.0  # [m]
    theta: float = 0.0  # [rad] wrapped
    cov: tuple[float, ...] = m.ZERO_COV  # 3x3 row-major over (x, y, theta)
    imu: hd.Imu = hd.Imu()
    compass: hd.Compass = hd.Compass()
    watch: stall.Watch = stall.Watch()  # each encoder's silence while commanded
    wheels: tuple[subtick.Wheel, subtick.Wheel] = (subtick.Wheel(), subtick.Wheel())  # (left, right) within their ticks


def tick_delta(new: int, old: int) -> int:
    """new - old of a signed 32-bit counter that wraps around."""
    return (new - old + 2**31) % 2**32 - 2**31


def _propagate(
    cov: tuple[float, ...],
    st: integrators.Step,
    h: hd.HeadingStep,
    p: Params,
    d_left: float,
    d_right: float,
    unmeasured: tuple[float, float],
) -> tuple[float, ...]:
    """P' = F P F^T + J Q J^T + var g g^T: state, wheels (and travel no encoder saw), heading source.

    3x3 work in plain floats (numpy's per-call cost is larger than the arithmetic here)."""
    (g00, g01), (g10, g11), (g20, g21) = st.G
    (f00, f01, f02), (f10, f11, f12), (f20, f21, f22) = st.F
    # dtheta = (1 - keep) (heading - theta_old) + ...: that share of the old heading drops out
    drop = 1.0 - h.keep
    f02, f12, f22 = f02 - drop * g01, f12 - drop * g11, f22 - drop * g21
    w = h.enc_weight / p.track
    q_l = p.k_left * abs(d_left) + unmeasured[0] ** 2  # [m^2] left travel
    q_r = p.k_right * abs(d_right) + unmeasured[1] ** 2  # [m^2] right travel
    # J = G [[0.5, 0.5], [-w, w]]: d pose / d (d_left, d_right); g = G[:, 1]: d pose / d heading
    l0, l1, l2 = 0.5 * g00 - w * g01, 0.5 * g10 - w * g11, 0.5 * g20 - w * g21
    r0, r1, r2 = 0.5 * g00 + w * g01, 0.5 * g10 + w * g11, 0.5 * g20 + w * g21
    v = h.var
    p00, p01, p02, p10, p11, p12, p20, p21, p22 = cov
    a00, a01, a02 = f00 * p00 + f01 * p10 + f02 * p20, f00 * p01 + f01 * p11 + f02 * p21, f00 * p02 + f01 * p12 + f02 * p22
    a10, a11, a12 = f10 * p00 + f11 * p10 + f12 * p20, f10 * p01 + f11 * p11 + f12 * p21, f10 * p02 + f11 * p12 + f12 * p22
    a20, a21, a22 = f20 * p00 + f21 * p10 + f22 * p20, f20 * p01 + f21 * p11 + f22 * p21, f20 * p02 + f21 * p12 + f22 * p22
    c00 = a00 * f00 + a01 * f01 + a02 * f02 + q_l * l0 * l0 + q_r * r0 * r0 + v * g01 * g01
    c01 = a00 * f10 + a01 * f11 + a02 * f12 + q_l * l0 * l1 + q_r * r0 * r1 + v * g01 * g11
    c02 = a00 * f20 + a01 * f21 + a02 * f22 + q_l * l0 * l2 + q_r * r0 * r2 + v * g01 * g21
    c11 = a10 * f10 + a11 * f11 + a12 * f12 + q_l * l1 * l1 + q_r * r1 * r1 + v * g11 * g11
    c12 = a10 * f20 + a11 * f21 + a12 * f22 + q_l * l1 * l2 + q_r * r1 * r2 + v * g11 * g21
    c22 = a20 * f20 + a21 * f21 + a22 * f22 + q_l * l2 * l2 + q_r * r2 * r2 + v * g21 * g21
    return (c00, c01, c02, c01, c11, c12, c02, c12, c22)  # symmetric: the upper triangle mirrored


def _travel(
    wheels: tuple[subtick.Wheel, subtick.Wheel], p: Params, ticks: tuple[int, int], t: float, dt: float, cmd: tuple[float, float]
) -> tuple[tuple[subtick.Wheel, subtick.Wheel], tuple[float, float]]:
    """Each wheel's sub-tick state and travel [m] over a step in which the counts moved `ticks`, commanded `cmd` [rad/s]."""
    if not p.subtick:
        return wheels, (ticks[0] * p.metres_per_tick, ticks[1] * p.metres_per_tick)
    per_rad = p.stall.ticks_per_rad
    left, right = (subtick.step(w, n, t, dt, c * per_rad, p.motor_lag) for w, n, c in zip(wheels, ticks, cmd))
    d_left = subtick.travel(wheels[0], left, ticks[0]) * p.metres_per_tick
    d_right = subtick.travel(wheels[1], right, ticks[1]) * p.metres_per_tick
    return (left, right), (d_left, d_right)


def update(
    s: OdometryState, p: Params, left: int, right: int, t: float, cmd: tuple[float, float] = (0.0, 0.0)
) -> tuple[OdometryState, m.Odom | None, str]:
    """One encoder sample (cumulative ticks, time t [s], the wheel speeds commanded meanwhile [rad/s]):
    new state, odom or None, event.

    A wheel commanded to turn whose encoder shows nothing (s.watch.silent) adds the
    travel it was commanded to the covariance, as unmeasured (stall.py).
    """
    if s.t is None:
        return s._replace(t=t, t0=t, left=left, right=right), None, BASELINE
    dt = t - s.t
    if dt <= 0.0:  # duplicate or out of order
        return s, None, STALE
    n_left, n_right = tick_delta(left, s.left), tick_delta(right, s.right)
    watch, unmeasured, _ = stall.step(s.watch, p.stall, t, dt, (n_left, n_right), cmd)
    limit = p.max_tick_rate * dt + 1.0  # one tick of quantisation always passes
    if abs(n_left) > limit or abs(n_right) > limit:
        return s._replace(t=t, left=left, right=right, t_moved=t, watch=watch, wheels=OdometryState().wheels), None, RESET
    wheels, (d_left, d_right) = _travel(s.wheels, p, (n_left, n_right), t, dt, cmd)
    d = (d_left + d_right) / 2.0
    imu, compass, h = hd.heading_step(s.imu, s.compass, s.theta, s.t0, t, dt, (d_right - d_left) / p.track, d / dt, p.heading)
    st = integrators.step(s.x, s.y, s.theta, d, h.dtheta, p.integrator)
    cov = _propagate(s.cov, st, h, p, d_left, d_right, unmeasured)
    t_moved = s.t_moved
    if n_left or n_right:
        t_moved, imu = t, hd.moved(imu)
    state = s._replace(
        t=t,
        left=left,
        right=right,
        x=st.x,
        y=st.y,
        theta=st.theta,
        cov=cov,
        imu=imu,
        compass=compass,
        watch=watch,
        t_moved=t_moved,
        wheels=wheels,
    )
    odom = m.Odom(
        t=t,
        x=st.x,
        y=st.y,
        theta=st.theta,
        v=d / dt,
        omega=h.omega,
        cov=cov,
        unmeasured_left=unmeasured[0],
        unmeasured_right=unmeasured[1],
    )
    return state, odom, FALLBACK if h.fallback else OK


def on_imu(s: OdometryState, p: Params, t: float, gyro_z: float, accel_y: float) -> tuple[OdometryState, str]:
    """One IMU sample: gyro_z [rad/s], accel_y [m/s^2] body frame; event OK or STALE."""
    if s.imu.t is not None and t <= s.imu.t:
        return s, STALE
    still = s.t is not None and t - s.t_moved >= p.heading.still_time
    return s._replace(imu=hd.imu_sample(s.imu, t, gyro_z, accel_y, still, p.heading)), OK


def on_compass(s: OdometryState, t: float, heading: float) -> tuple[OdometryState, str]:
    """One compass heading [rad, map frame]; event OK or STALE."""
    if s.compass.t is not None and t <= s.compass.t:
        return s, STALE
    at_start = s.t_moved == -math.inf  # no wheel has moved since the first sample
    return s._replace(compass=hd.compass_sample(s.compass, t, heading, s.theta, at_start)), OK
