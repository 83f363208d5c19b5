"""The estimates of one step (the estimate_average mode), every distance with every angle change, and their weighted average.

Distances of a step: the encoders' and the accelerometer's (forward acceleration
integrated twice by the secant rule). Angle changes: the encoders', the gyro's
and the accelerometer's (the lateral travel a_y dt^2 / 2 over the forward travel is
the chord angle atan(dy / dx), half the heading change of the arc). Each distance
with each angle change is one estimate of the step (dx, dy) in the field frame; x and
y are the weighted averages of those six, with weight = distance weight x angle weight,
and the heading change is the weighted average of the angle changes.

The accelerometer drifts: while the encoders show no forward travel (a stop, a turn in
place) and it feels no push, its forward speed is known to be zero, and while the robot stands still its
samples refine the accelerometer and gyro biases. With no forward travel the
accelerometer's angle is undefined and left out. Pure: samples and times come in as arguments and functions return new state.
"""

from __future__ import annotations

import math
from typing import NamedTuple

MIN_TRAVEL = 1e-4  # [m] below this forward travel the accelerometer's angle is not defined
STILL_RATE = 0.02  # [rad/s] a gyro rate (bias removed) above this is motion, not bias
STILL_ACCEL = 0.5  # [m/s^2] an acceleration (bias removed) above this is motion, not bias


class Inertial(NamedTuple):
    """The IMU integrated since the last odometry step, and its biases learned while still."""

    t: float | None = None  # [s] newest sample
    gyro: float = 0.0  # [rad/s] yaw rate at t, bias removed
    ax: float = 0.0  # [m/s^2] forward acceleration at t, bias removed
    ay: float = 0.0  # [m/s^2] lateral acceleration at t, bias removed
    v: float = 0.0  # [m/s] forward speed integrated from ax
    angle: float = 0.0  # [rad] gyro angle since the last step
    travel: float = 0.0  # [m] forward travel since the last step
    lateral: float = 0.0  # [m] lateral travel since the last step (lateral speed zero at its start)
    vy: float = 0.0  # [m/s] lateral speed since the last step
    bias_gyro: float = 0.0  # [rad/s]
    bias_ax: float = 0.0  # [m/s^2]
    bias_ay: float = 0.0  # [m/s^2]
    still_samples: int = 0  # samples averaged into the biases


def imu_sample(
    s: Inertial, t: float, gyro_z: float, accel_x: float, accel_y: float, halted: bool, still: bool, bias_time: float
) -> Inertial:
    """Take one IMU sample (t newer than s.t); `halted`: the encoders show no forward travel for a while,
    `still`: no motion at all.

    Secant rule: dv = (a0 + da / 2) dt, dd = (v0 + dv / 2) dt.
    """
    dt = 0.0 if s.t is None else t - s.t
    bg, bx, by, n = s.bias_gyro, s.bias_ax, s.bias_ay, s.still_samples
    if still and abs(gyro_z - bg) < STILL_RATE and abs(accel_x - bx) < STILL_ACCEL and abs(accel_y - by) < STILL_ACCEL:
        n += 1
        k = min(1.0, max(1.0 / n, dt / bias_time))
        bg, bx, by = bg + k * (gyro_z - bg), bx + k * (accel_x - bx), by + k * (accel_y - by)
    g, ax, ay = gyro_z - bg, accel_x - bx, accel_y - by
    if still and abs(g) < STILL_RATE:
        g = 0.0
    angle = s.angle + 0.5 * (s.gyro + g) * dt
    if (halted or still) and abs(ax) < STILL_ACCEL:  # no travel, no push felt: the forward speed is zero
        return Inertial(t, g, 0.0, 0.0, 0.0, angle, s.travel, s.lateral, 0.0, bg, bx, by, n)
    dv = 0.5 * (s.ax + ax) * dt
    dvy = 0.5 * (s.ay + ay) * dt
    return Inertial(
        t,
        g,
        ax,
        ay,
        s.v + dv,
        angle,
        s.travel + (s.v + 0.5 * dv) * dt,
        s.lateral + (s.vy + 0.5 * dvy) * dt,
        s.vy + dvy,
        bg,
        bx,
        by,
        n,
    )


def take(s: Inertial) -> tuple[Inertial, float, float, float | None]:
    """(state restarted for the next step, gyro angle [rad], forward travel [m], accelerometer angle [rad] or None)."""
    accel_angle = 2.0 * math.atan(s.lateral / s.travel) if abs(s.travel) >= MIN_TRAVEL else None
    return s._replace(angle=0.0, travel=0.0, lateral=0.0, vy=0.0), s.angle, s.travel, accel_angle


def combine(
    theta: float,
    distances: tuple[float | None, ...],
    angles: tuple[float | None, ...],
    w_dist: tuple[float, ...],
    w_angle: tuple[float, ...],
) -> tuple[float, float, float]:
    """(dx, dy [m] field frame, dtheta [rad]) of a step from heading theta [rad]: the weighted averages.

    Each distance with each angle change gives (d cos(theta + a / 2), d sin(theta + a / 2));
    a missing sensor (None) or a zero weight leaves its estimates out. The encoders
    (first of each) are always there.
    """
    a_num = a_den = 0.0
    for a, w in zip(angles, w_angle):
        if a is not None and w > 0.0:
            a_num, a_den = a_num + w * a, a_den + w
    dtheta = a_num / a_den if a_den > 0.0 else float(angles[0] or 0.0)
    x = y = den = 0.0
    for d, wd in zip(distances, w_dist):
        if d is None or wd <= 0.0:
            continue
        for a, wa in zip(angles, w_angle):
            if a is None or wa <= 0.0:
                continue
            w, h = wd * wa, theta + a / 2.0
            x, y, den = x + w * d * math.cos(h), y + w * d * math.sin(h), den + w
    if den <= 0.0:
        d0 = float(distances[0] or 0.0)
        return d0 * math.cos(theta + dtheta / 2.0), d0 * math.sin(theta + dtheta / 2.0), dtheta
    return x / den, y / den, dtheta
