"""Inverse kinematics and the wheel command limits."""

import math

import pytest

from zenav.services.motor import kinematics as kin

R, L = 0.0673 / 2.0, 0.1156  # nominal wheel radius and track [m]
LIM = kin.Limits(radius=R, track=L, max_speed=10.0, max_accel=40.0, deadband=0.5)


def curvature(left, right):
    """omega / v of wheel speeds (inf when turning in place)."""
    v, omega = R * (left + right) / 2.0, R * (right - left) / L
    return math.inf if v == 0.0 else omega / v


def test_inverse_kinematics():
    assert kin.inverse(0.2, 0.0, R, L) == pytest.approx((0.2 / R, 0.2 / R))
    assert kin.inverse(0.0, 1.0, R, L) == pytest.approx((-L / 2 / R, L / 2 / R))
    left, right = kin.inverse(0.15, -0.8, R, L)
    assert R * (left + right) / 2 == pytest.approx(0.15) and R * (right - left) / L == pytest.approx(-0.8)


@pytest.mark.parametrize("v, omega", [(0.5, 0.0), (0.3, 2.0), (-0.4, 1.5), (0.0, 8.0), (0.5, -6.0)])
def test_saturation_scales_both_wheels_and_keeps_the_curvature(v, omega):
    left, right = kin.inverse(v, omega, R, L)
    sl, sr = kin.saturate(left, right, 10.0)
    assert max(abs(sl), abs(sr)) == pytest.approx(min(10.0, max(abs(left), abs(right))))
    assert curvature(sl, sr) == pytest.approx(curvature(left, right))
    assert sl / left == pytest.approx(sr / right)


def test_saturation_leaves_commands_within_the_limit():
    assert kin.saturate(3.0, -9.99, 10.0) == (3.0, -9.99)


def test_acceleration_limit_moves_by_at_most_max_accel_dt_along_the_line():
    # from rest to (8, 4) with 0.4 rad/s per step: the larger change is limited, the other in proportion
    assert kin.limit_accel(8.0, 4.0, 0.0, 0.0, 40.0, 0.01) == pytest.approx((0.4, 0.2))
    assert kin.limit_accel(8.0, 4.0, 7.8, 4.0, 40.0, 0.01) == (8.0, 4.0)  # within reach
    assert kin.limit_accel(-5.0, 5.0, 5.0, 5.0, 40.0, 0.05) == pytest.approx((3.0, 5.0))
    assert kin.limit_accel(1.0, 1.0, 0.0, 0.0, 40.0, 0.0) == (0.0, 0.0)  # no time, no change


def test_deadband_raises_small_commands_and_keeps_zero():
    assert kin.deadband(0.0, 0.5) == 0.0
    assert kin.deadband(0.2, 0.5) == 0.5 and kin.deadband(-0.01, 0.5) == -0.5
    assert kin.deadband(0.7, 0.5) == 0.7 and kin.deadband(-3.0, 0.5) == -3.0


def test_wheel_command_ramps_from_rest_keeping_the_curvature():
    ramp, outs = (0.0, 0.0), []
    for _ in range(40):
        ramp, out = kin.wheel_command(0.25, 1.0, ramp, 0.01, LIM)
        outs.append(out)
    target = kin.inverse(0.25, 1.0, R, L)  # (6.5, 8.9) rad/s
    assert outs[-1] == pytest.approx(target)
    for (l0, r0), (l1, r1) in zip(outs[1:], outs[2:]):
        assert max(abs(l1 - l0), abs(r1 - r0)) <= 0.4 + 1e-12
    assert outs[0] == (0.5, 0.5)  # (0.29, 0.4) raised to the deadband
    assert all(curvature(*o) == pytest.approx(1.0 / 0.25) for o in outs[2:])  # past the deadband


def test_wheel_command_zero_stops_at_once():
    assert kin.wheel_command(0.0, 0.0, (9.0, 9.0), 0.01, LIM) == ((0.0, 0.0), (0.0, 0.0))


def test_wheel_command_slow_turn_is_raised_to_the_deadband():
    ramp, out = kin.wheel_command(0.005, 0.0, (0.0, 0.0), 0.1, LIM)
    assert ramp == pytest.approx((0.005 / R, 0.005 / R)) and out == (0.5, 0.5)  # 0.15 rad/s would not turn
