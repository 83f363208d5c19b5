"""Braking profiles: command a speed from which the robot can still stop at the target.

speed = clamp(sqrt(2 * decel * remaining), min, max): constant deceleration into the
target, and never slower than `min` so the wheels stay above the motor deadband.
The remaining distance is the one predicted `lead` seconds ahead at the measured
rate, so the motor lag does not carry the robot past the target: the turn stops
where the prediction reaches the target, and the coast takes it the rest of the way.
"""

from __future__ import annotations

import math


def profile_speed(remaining: float, decel: float, low: float, high: float) -> float:
    """Speed magnitude [unit/s] that brakes at `decel` [unit/s^2] into `remaining` [unit]."""
    return max(low, min(high, math.sqrt(2.0 * decel * max(remaining, 0.0))))


def turn_command(error: float, omega: float, speed: float, tolerance: float, decel: float, low: float, lead: float) -> float | None:
    """Turn rate [rad/s] for a heading `error` [rad] while turning at `omega`; None once arrived.

    Arrived: the heading predicted `lead` [s] ahead reaches the target (the coast takes
    it there), or the robot is at rest within tolerance (a turn that starts there).
    """
    ahead = error - omega * lead  # [rad] predicted error after the lead
    if ahead * error <= 0.0 or (omega == 0.0 and abs(error) <= tolerance):
        return None
    return math.copysign(profile_speed(abs(ahead), decel, low, speed), error)
