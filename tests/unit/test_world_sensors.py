"""The robot's sensors: encoder quantisation and wrap, IMU errors, compass disturbance."""

import math

import msgspec
import numpy as np
import pytest

from zenav.common.scenarios import PRESETS, Scenario
from zenav.world import sensors
from zenav.world.robot import State

QUIET = Scenario(gyro_noise_dps=0.0, accel_noise=0.0, compass_noise_deg=0.0)


def test_encoder_quantisation():
    tick = 2 * math.pi / 360
    assert sensors.encoder_ticks(10.5 * tick, 360) == 10
    assert sensors.encoder_ticks(9.999 * tick, 360) == 9
    assert sensors.encoder_ticks(-0.1 * tick, 360) == -1  # floor, not truncation
    assert sensors.encoder_ticks(2 * math.pi * 3.5, 16) == 56
    assert sensors.encoder_ticks(2 * math.pi * 3.5, 16, start=100) == 156


def test_encoder_wraps_signed_32_bit():
    tick = 2 * math.pi / 360
    start = 2**31 - 5
    assert sensors.encoder_ticks(4.5 * tick, 360, start) == 2**31 - 1
    assert sensors.encoder_ticks(10.5 * tick, 360, start) == -(2**31) + 5
    assert sensors.encoder_ticks(-10.5 * tick, 360, -(2**31) + 5) == 2**31 - 6
    assert sensors.wrap_int32(2**32 + 7) == 7


def test_gyro_scale_and_bias():
    s = State(omega=1.0)
    gyro, _, _ = sensors.imu(s, QUIET, np.random.default_rng(1))
    assert gyro == pytest.approx(1.0 * 1.01 + math.radians(0.5))


def test_gyro_bias_and_noise_statistics():
    scen = PRESETS["harsh"]
    rng = np.random.default_rng(2)
    g = np.array([sensors.imu(State(), scen, rng)[0] for _ in range(5000)])
    assert g.mean() == pytest.approx(math.radians(1.0), abs=3 * math.radians(0.5) / math.sqrt(5000))
    assert g.std() == pytest.approx(math.radians(0.5), rel=0.05)


def test_accelerometer_forward_and_centripetal():
    s = State(v=0.2, omega=1.5, accel=0.3)
    _, ax, ay = sensors.imu(s, QUIET, np.random.default_rng(1))
    assert ax == pytest.approx(0.3 + 0.02)
    assert ay == pytest.approx(0.2 * 1.5 + 0.02)
    rng = np.random.default_rng(4)
    noisy = np.array([sensors.imu(State(), PRESETS["default"], rng)[1:] for _ in range(5000)])
    assert noisy.mean(axis=0) == pytest.approx([0.02, 0.02], abs=0.005)
    assert noisy.std(axis=0) == pytest.approx([0.05, 0.05], rel=0.05)


def test_compass_disturbance_inside_its_spot_only():
    scen = msgspec.structs.replace(PRESETS["harsh"], compass_noise_deg=0.0)
    rng = np.random.default_rng(1)
    assert sensors.compass(State(x=0.6, y=0.4, theta=0.2), scen, rng) == pytest.approx(0.2 + math.radians(10.0))
    assert sensors.compass(State(x=0.9, y=0.5, theta=0.2), scen, rng) == pytest.approx(0.2)
    assert sensors.compass(State(x=0.6, y=0.4, theta=0.2), QUIET, rng) == pytest.approx(0.2)  # default: none


def test_compass_wraps_and_is_noisy():
    scen = Scenario(compass_disturbance_deg=20.0, compass_noise_deg=0.0)
    h = sensors.compass(State(x=0.5, y=0.5, theta=math.pi - 0.1), scen, np.random.default_rng(1))
    assert h == pytest.approx(-math.pi - 0.1 + math.radians(20.0))
    rng = np.random.default_rng(5)
    headings = np.array([sensors.compass(State(), PRESETS["default"], rng) for _ in range(5000)])
    assert headings.std() == pytest.approx(math.radians(3.0), rel=0.05)
