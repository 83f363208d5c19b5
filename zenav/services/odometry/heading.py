"""Heading sources of one odometry step: encoders, gyro, compass, or a blend of them.

Pure: samples and times come in as arguments and every function returns new state.
The gyro is integrated into a heading of its own (trapezoid rule); a step takes the
change of that heading between two encoder times, extrapolated with the newest rate
when the IMU sample of that instant has not arrived yet (the next step makes up the
difference). While the robot stands still (no tick for `still_time` and a small
rate) the gyro reads zero and its samples refine the bias estimate. The compass is
an absolute heading in the map frame; the odom frame's offset to it is the mean of
the samples taken before the robot first moves. The encoders carry the heading and
each compass sample pulls it a fraction `compass_gain` of the way (a complementary
filter), so odom stays continuous (REP-105) while its heading no longer drifts.
"""

from __future__ import annotations

from typing import NamedTuple

from zenav.common.geometry import wrap_angle

# Still samples wait this many samples before they join the bias average: motion shows
# in the gyro a sample or two before the first encoder tick, and must not become bias.
BIAS_DELAY = 5  # [samples]


class HeadingParams(NamedTuple):
    """How the heading of a step is found."""

    source: str  # encoders, gyro, compass or blend
    weights: tuple[float, float, float]  # blend: encoders, gyro, accelerometer [-]
    gyro_var_rate: float  # [rad^2/s] heading variance the gyro adds per second
    accel_var_rate: float  # [rad^2/s] heading variance the accelerometer adds per second
    compass_var: float  # [rad^2] variance of one compass heading
    compass_gain: float  # fraction of the way each compass sample pulls the heading (1: replace it) [-]
    still_time: float  # [s] no encoder tick for this long: the robot stands still
    still_rate: float  # [rad/s] a gyro rate (bias removed) above this is motion, not bias
    bias_time: float  # [s] time constant of the gyro bias average
    accel_min_speed: float  # [m/s] below this the centripetal rate a_y / v is not used
    imu_timeout: float  # [s] an IMU silent for longer is missing (its rate was extrapolated until then)
    compass_timeout: float  # [s] a compass silent for longer is missing


class Imu(NamedTuple):
    """The gyro's own integrated heading and bias, and the newest lateral acceleration."""

    t: float | None = None  # [s] newest sample
    rate: float = 0.0  # [rad/s] yaw rate at t, bias removed; 0 while still
    angle: float = 0.0  # [rad] gyro heading integrated up to t, unwrapped
    bias: float = 0.0  # [rad/s] learned while still
    still_samples: int = 0  # samples averaged into the bias so far
    pending: tuple[float, ...] = ()  # [rad/s] newest still samples, not yet in the bias
    accel_y: float = 0.0  # [m/s^2] lateral (centripetal) acceleration at t, body frame
    ref: float | None = None  # [rad] gyro heading at the previous odometry step

    def angle_at(self, t: float) -> float:
        """The gyro heading at time t [s], extrapolated from the newest sample."""
        return self.angle if self.t is None else self.angle + self.rate * (t - self.t)


class Compass(NamedTuple):
    """The newest compass heading, in the odom frame."""

    t: float | None = None  # [s] newest sample
    heading: float = 0.0  # [rad] odom frame
    offset: float | None = None  # [rad] map heading of the odom x axis, fixed at the start
    samples: int = 0  # samples averaged into the offset
    fresh: bool = False  # not yet applied to the pose


class HeadingStep(NamedTuple):
    """The heading change of one step and what the covariance needs to know about it."""

    dtheta: float  # [rad]
    omega: float  # [rad/s] yaw rate reported with the step
    enc_weight: float  # share of the encoders' heading change in dtheta [-]
    var: float  # [rad^2] variance of dtheta not due to the wheels
    keep: float  # fraction of the old heading the new one keeps (1; compass: 1 - gain) [-]
    fallback: bool  # the source's sensor is missing: encoders only


def imu_sample(imu: Imu, t: float, gyro_z: float, accel_y: float, still: bool, p: HeadingParams) -> Imu:
    """Take one IMU sample (t newer than imu.t); `still`: no encoder tick for still_time."""
    dt = 0.0 if imu.t is None else t - imu.t
    bias, n = imu.bias, imu.still_samples
    still = still and abs(gyro_z - bias) < p.still_rate
    pending = imu.pending + (gyro_z,) if still else ()
    if len(pending) > BIAS_DELAY:
        n += 1
        # The plain mean of the first samples, then an exponential average.
        bias += (pending[0] - bias) * min(1.0, max(1.0 / n, dt / p.bias_time))
        pending = pending[1:]
    rate = 0.0 if still else gyro_z - bias
    angle = imu.angle + 0.5 * (imu.rate + rate) * dt
    return Imu(t, rate, angle, bias, n, pending, accel_y, imu.ref)


def moved(imu: Imu) -> Imu:
    """A wheel moved: the still samples not yet trusted were motion after all."""
    return imu._replace(pending=())


def compass_sample(c: Compass, t: float, heading: float, theta: float, at_start: bool) -> Compass:
    """Take one compass heading [rad, map frame]; theta [rad] is the odom heading now.

    Until the robot first moves (`at_start`) its samples only refine the offset, as a mean.
    """
    if c.offset is None:
        offset, n = wrap_angle(heading - theta), 1
    elif at_start:
        n = c.samples + 1
        offset = wrap_angle(c.offset + wrap_angle(heading - theta - c.offset) / n)
    else:
        offset, n = c.offset, c.samples
    return Compass(t, wrap_angle(heading - offset), offset, n, not at_start)


def heading_step(
    imu: Imu,
    compass: Compass,
    theta: float,
    t0: float,
    t: float,
    dt: float,
    enc_dtheta: float,
    v: float,
    p: HeadingParams,
) -> tuple[Imu, Compass, HeadingStep]:
    """The heading change over the encoder step ending at t [s] (dt [s] long, speed v [m/s]).

    theta [rad] is the odom heading before the step; a sensor with no sample since t0 [s]
    counts as missing only once the timeout has passed since t0.
    """
    enc = HeadingStep(enc_dtheta, enc_dtheta / dt, 1.0, 0.0, 1.0, False)
    if p.source == "encoders":
        return imu, compass, enc
    if p.source == "compass":
        if compass.fresh and compass.t is not None:
            # The sample's heading carried to t with the encoders' rate, blended in by the gain.
            g = p.compass_gain
            innovation = wrap_angle(compass.heading + enc.omega * (t - compass.t) - (theta + enc_dtheta))
            step = HeadingStep(enc_dtheta + g * innovation, enc.omega, 1.0 - g, g * g * p.compass_var, 1.0 - g, False)
            return imu, compass._replace(fresh=False), step
        missing = t - (t0 if compass.t is None else compass.t) > p.compass_timeout
        return imu, compass, enc._replace(fallback=missing)
    gyro_missing = t - (t0 if imu.t is None else imu.t) > p.imu_timeout
    gyro_ok = imu.t is not None and not gyro_missing
    angle = imu.angle_at(t) if gyro_ok else None
    gyro_dtheta = None if angle is None or imu.ref is None else angle - imu.ref
    imu = imu._replace(ref=angle)
    w_enc, w_gyro, w_accel = p.weights if p.source == "blend" else (0.0, 1.0, 0.0)
    parts = [(w_enc, enc_dtheta, 0.0)]
    if gyro_dtheta is not None:
        parts.append((w_gyro, gyro_dtheta, p.gyro_var_rate * dt))
    if gyro_ok and abs(v) >= p.accel_min_speed:
        # Centripetal a_y = v omega. (The chord angle atan(dy/dx) of the doubly integrated
        # accelerations, with the lateral speed zero at the step's start, is the chord
        # angle a_y dt / (2 v): half of this heading change.)
        parts.append((w_accel, imu.accel_y / v * dt, p.accel_var_rate * dt))
    total = sum(w for w, _, _ in parts)
    if total <= 0.0:
        return imu, compass, enc._replace(fallback=gyro_missing)
    dtheta = sum(w * d for w, d, _ in parts) / total
    var = sum((w / total) ** 2 * q for w, _, q in parts)
    return imu, compass, HeadingStep(dtheta, dtheta / dt, w_enc / total, var, 1.0, gyro_missing)
