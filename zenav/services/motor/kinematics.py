"""Differential-drive inverse kinematics and the limits on wheel commands.

Pure: time comes in as dt. A command goes through `wheel_command`: inverse
kinematics, saturation that keeps the curvature, an acceleration limit from the
previous command, then deadband compensation.
"""

from __future__ import annotations

import math
from typing import NamedTuple


class Limits(NamedTuple):
    """The nominal geometry and the limits of the wheel commands."""

    radius: float  # [m] nominal wheel radius
    track: float  # [m] nominal track width
    max_speed: float  # [rad/s] per wheel
    max_accel: float  # [rad/s^2] per wheel
    deadband: float  # [rad/s] the motors do not turn below this command


def inverse(v: float, omega: float, radius: float, track: float) -> tuple[float, float]:
    """Wheel angular velocities [rad/s] (left, right) for v [m/s] and omega [rad/s]."""
    return (v - omega * track / 2.0) / radius, (v + omega * track / 2.0) / radius


def saturate(left: float, right: float, max_speed: float) -> tuple[float, float]:
    """Scale both wheels by one factor so neither exceeds max_speed: the curvature is kept."""
    top = max(abs(left), abs(right))
    if top <= max_speed:
        return left, right
    k = max_speed / top
    return left * k, right * k


def limit_accel(left: float, right: float, last_left: float, last_right: float, max_accel: float, dt: float) -> tuple[float, float]:
    """Move from the last output towards (left, right) by at most max_accel * dt per wheel.

    Both changes shrink by one factor, so a start from rest keeps the commanded curvature.
    """
    step = max_accel * dt
    top = max(abs(left - last_left), abs(right - last_right))
    if top <= step:
        return left, right
    k = step / top
    return last_left + (left - last_left) * k, last_right + (right - last_right) * k


def deadband(w: float, band: float) -> float:
    """Raise a non-zero command below the deadband to it (keeping the sign); zero stays zero."""
    if w == 0.0 or abs(w) >= band:
        return w
    return math.copysign(band, w)


def wheel_command(
    v: float, omega: float, ramp: tuple[float, float], dt: float, lim: Limits
) -> tuple[tuple[float, float], tuple[float, float]]:
    """(ramp, output) [rad/s] for (v, omega), dt [s] after the previous ramp value.

    The ramp is the acceleration-limited command; the output adds deadband compensation
    to it, so the compensation never bends a ramp from rest off the commanded curvature.
    A zero command stops at once: it may be the last command sent, and a ramp would
    leave the wheels turning until the watchdog.
    """
    if v == 0.0 and omega == 0.0:
        return (0.0, 0.0), (0.0, 0.0)
    left, right = saturate(*inverse(v, omega, lim.radius, lim.track), lim.max_speed)
    left, right = limit_accel(left, right, ramp[0], ramp[1], lim.max_accel, dt)
    return (left, right), (deadband(left, lim.deadband), deadband(right, lim.deadband))
