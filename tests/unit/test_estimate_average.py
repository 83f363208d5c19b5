"""The 12-estimate average: the accelerometer's secant-rule integration, the weighted averages, the estimate_average mode."""

from __future__ import annotations

import math

import msgspec
import pytest

from zenav.common import messages as m
from zenav.common.config import RobotConfig
from zenav.services.localizer import averaging
from zenav.services.localizer.base import LocalizerConfig
from zenav.services.localizer.modes import make_mode


def test_secant_rule_is_exact_for_a_constant_acceleration():
    s = averaging.imu_sample(averaging.Inertial(), 0.0, 0.0, 0.5, 0.0, halted=False, still=False, bias_time=5.0)
    for i in range(1, 101):
        s = averaging.imu_sample(s, i * 0.01, 0.0, 0.5, 0.0, halted=False, still=False, bias_time=5.0)
    assert s.v == pytest.approx(0.5)  # [m/s] after 1 s at 0.5 m/s^2
    s, gyro, travel, angle = averaging.take(s)
    assert travel == pytest.approx(0.25)  # a t^2 / 2
    assert gyro == 0.0 and angle == pytest.approx(0.0)
    assert (s.travel, s.angle, s.v) == (0.0, 0.0, pytest.approx(0.5))  # the speed carries over to the next step


def test_accelerometer_angle_is_the_heading_change_of_the_arc():
    v, omega, dt = 0.3, 1.0, 0.01  # [m/s], [rad/s], [s]
    s = averaging.Inertial(t=0.0, gyro=omega, v=v, ay=v * omega)
    s = averaging.imu_sample(s, dt, omega, 0.0, v * omega, halted=False, still=False, bias_time=5.0)
    _, gyro, travel, angle = averaging.take(s)
    assert travel == pytest.approx(v * dt)
    assert gyro == pytest.approx(omega * dt)
    assert angle == pytest.approx(omega * dt, rel=1e-3)


def test_no_forward_travel_leaves_the_accelerometer_angle_out():
    _, _, travel, angle = averaging.take(averaging.Inertial(t=0.0, lateral=1e-4))
    assert travel == 0.0 and angle is None


def test_standing_still_learns_the_biases_and_zeroes_the_speed():
    s = averaging.Inertial(v=0.2)
    for i in range(200):
        s = averaging.imu_sample(s, i * 0.01, 0.01, 0.03, -0.02, halted=True, still=True, bias_time=5.0)
    assert (s.bias_gyro, s.bias_ax, s.bias_ay) == (pytest.approx(0.01), pytest.approx(0.03), pytest.approx(-0.02))
    assert s.v == 0.0 and s.angle == 0.0


def test_a_push_while_halted_is_not_taken_for_rest():
    s = averaging.Inertial(t=0.0)
    s = averaging.imu_sample(s, 0.01, 0.0, 2.0, 0.0, halted=True, still=False, bias_time=5.0)
    assert s.v == pytest.approx(0.01)  # the motor's first push before the first encoder tick counts


def test_combine_is_the_weighted_average_of_the_six_estimates():
    theta, d_enc, d_acc = 0.3, 0.010, 0.012
    angles = (0.02, 0.01, 0.04)
    wd, wa = (1.0, 0.5), (1.0, 3.0, 0.5)
    dx, dy, dth = averaging.combine(theta, (d_enc, d_acc), angles, wd, wa)
    pairs = [(i * j, d, a) for i, d in zip(wd, (d_enc, d_acc)) for j, a in zip(wa, angles)]
    total = sum(w for w, _, _ in pairs)
    assert dx == pytest.approx(sum(w * d * math.cos(theta + a / 2) for w, d, a in pairs) / total)
    assert dy == pytest.approx(sum(w * d * math.sin(theta + a / 2) for w, d, a in pairs) / total)
    assert dth == pytest.approx((0.02 + 3 * 0.01 + 0.5 * 0.04) / 4.5)


def test_combine_leaves_missing_sensors_out():
    assert averaging.combine(0.0, (0.01, None), (0.02, None, None), (1.0, 1.0), (1.0, 1.0, 1.0)) == pytest.approx(
        (0.01 * math.cos(0.01), 0.01 * math.sin(0.01), 0.02)
    )
    # Every weight zero: the encoders alone.
    assert averaging.combine(0.0, (0.01, 0.5), (0.0, 0.3, 0.3), (0.0, 0.0), (0.0, 0.0, 0.0)) == pytest.approx((0.01, 0.0, 0.0))


def mode(**overrides: object):
    return make_mode(msgspec.convert({"mode": "estimate_average", **overrides}, LocalizerConfig), RobotConfig())


def test_estimate_average_mode_averages_the_gyro_into_the_heading():
    loc = mode(estimate_average_angle_weights=(1.0, 1.0, 0.0))
    for i in range(11):  # the encoders say 0.1 rad/s, the gyro 0.3 rad/s
        t = i * 0.1
        loc.on_imu(m.Imu(t=t, gyro_z=0.3, accel_x=0.0, accel_y=0.0))
        loc.on_odom(m.Odom(t=t, x=0.0, y=0.0, theta=0.01 * i, v=0.0, omega=0.1))
    p = loc.get_pose()
    assert p is not None and p.theta == pytest.approx(0.2, abs=1e-6)  # (0.1 + 0.3) / 2 rad/s for 1 s


def test_estimate_average_mode_weights_a_fix_in():
    loc = mode(estimate_average_fix_weight=0.25, estimate_average_fix_heading_weight=0.5)
    loc.on_odom(m.Odom(t=0.0, x=0.0, y=0.0, theta=0.0, v=0.0, omega=0.0))
    rec = loc.on_fix(m.VpsPose(t=0.0, x=1.0, y=-2.0, theta=0.2), 0.3)
    p = loc.get_pose()
    assert rec.accepted and p is not None
    assert (p.x, p.y, p.theta) == pytest.approx((0.25, -0.5, 0.1))
