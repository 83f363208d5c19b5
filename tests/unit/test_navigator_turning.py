"""The decelerating turn profile, on a robot whose turn rate lags the command."""

import math

import pytest

from zenav.common.geometry import wrap_angle
from zenav.services.navigator.turning import profile_speed, turn_command

TOL = math.radians(1.0)


def test_profile_brakes_at_constant_deceleration_between_the_limits():
    assert profile_speed(0.5, 4.0, 0.4, 2.0) == pytest.approx(2.0)
    assert profile_speed(0.08, 4.0, 0.4, 2.0) == pytest.approx(math.sqrt(2 * 4.0 * 0.08))
    assert profile_speed(0.001, 4.0, 0.4, 2.0) == 0.4
    assert profile_speed(-1.0, 4.0, 0.4, 2.0) == 0.4
    speeds = [profile_speed(r / 100, 4.0, 0.4, 2.0) for r in range(100)]
    assert speeds == sorted(speeds)


def turn(target, lag=0.05, delay_steps=1, dt=0.01, seconds=5.0):
    """Turn from 0 to `target` with a first-order motor lag; (headings, commands)."""
    theta, omega, cmds, headings = 0.0, 0.0, [0.0] * delay_steps, []
    for _ in range(round(seconds / dt)):
        cmd = turn_command(wrap_angle(target - theta), cmds[-1], 2.0, TOL, 4.0, 0.4, 0.06)
        if cmd is None:
            cmds.append(0.0)
            break
        cmds.append(cmd)
        omega += (cmds[-1 - delay_steps] - omega) * (1 - math.exp(-dt / lag))
        theta += omega * dt
        headings.append(theta)
    for _ in range(100):  # coast to rest on zero
        omega += (0.0 - omega) * (1 - math.exp(-dt / lag))
        theta += omega * dt
        headings.append(theta)
    return headings, cmds


@pytest.mark.parametrize("target_deg", [3.0, 20.0, 90.0, -90.0, 179.0, -150.0])
def test_turns_arrive_without_overshoot_or_oscillation(target_deg):
    target = math.radians(target_deg)
    headings, cmds = turn(target)
    side = math.copysign(1.0, target)
    assert abs(headings[-1] - target) <= TOL
    assert max(side * (h - target) for h in headings) <= TOL  # never further past than the tolerance
    nonzero = [c for c in cmds if c != 0.0]
    assert all(math.copysign(1.0, c) == side for c in nonzero)  # never turns back: no oscillation


def test_arrived_when_the_prediction_reaches_the_target_or_at_rest_within_tolerance():
    assert turn_command(0.03, 0.6, 2.0, TOL, 4.0, 0.4, 0.06) is None  # outside tolerance, but coasting there
    assert turn_command(0.01, 0.0, 2.0, TOL, 4.0, 0.4, 0.06) is None  # at rest within tolerance
    assert turn_command(0.01, 0.1, 2.0, TOL, 4.0, 0.4, 0.06) == pytest.approx(0.4)  # turning: creeps in
    assert turn_command(-0.5, 0.0, 2.0, TOL, 4.0, 0.4, 0.06) == pytest.approx(-2.0)
