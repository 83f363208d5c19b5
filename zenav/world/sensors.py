"""The robot's sensors: encoders, IMU and compass, with the scenario's errors.

Pure: each reads a robot State and draws its noise from the generator passed in.
"""

from __future__ import annotations

import math

import numpy as np

from zenav.common.geometry import wrap_angle
from zenav.common.scenarios import Scenario
from zenav.world.robot import State


def wrap_int32(n: int) -> int:
    """An integer wrapped to a signed 32-bit counter, as the encoder hardware does."""
    return (n + 2**31) % 2**32 - 2**31


def encoder_ticks(angle: float, ticks_per_rev: int, start: int = 0) -> int:
    """The count of an encoder whose wheel has turned `angle` [rad] since it read `start` [ticks]."""
    return wrap_int32(math.floor(angle / (2.0 * math.pi) * ticks_per_rev) + start)


def imu(s: State, scen: Scenario, rng: np.random.Generator) -> tuple[float, float, float]:
    """(gyro_z [rad/s], accel_x, accel_y [m/s^2]) in the body frame, with bias, scale and noise."""
    n_gyro, n_ax, n_ay = rng.standard_normal(3).tolist()
    gyro_z = s.omega * (1.0 + scen.gyro_scale_err) + math.radians(scen.gyro_bias_dps) + math.radians(scen.gyro_noise_dps) * n_gyro
    accel_x = s.accel + scen.accel_bias + scen.accel_noise * n_ax
    accel_y = s.v * s.omega + scen.accel_bias + scen.accel_noise * n_ay  # centripetal
    return gyro_z, accel_x, accel_y


def compass(s: State, scen: Scenario, rng: np.random.Generator) -> float:
    """Heading [rad, map frame] with noise, offset by the fixed disturbance inside its spot (edge included)."""
    heading = s.theta + math.radians(scen.compass_noise_deg) * float(rng.standard_normal())
    spot = math.hypot(s.x - scen.compass_disturbance_x, s.y - scen.compass_disturbance_y)
    if spot <= scen.compass_disturbance_radius:
        heading += math.radians(scen.compass_disturbance_deg)
    return wrap_angle(heading)


def due(step: int, rate: float, sensor_rate: float) -> bool:
    """Whether a sensor at `rate` [Hz] samples on this step of the `sensor_rate` [Hz] grid (step 0 included)."""
    ratio = rate / sensor_rate
    return math.floor(step * ratio + 1e-6) > math.floor((step - 1) * ratio + 1e-6)
