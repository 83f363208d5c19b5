"""The reference scenarios of shared/spec/scenarios.md: how the simulated world
differs from the nominal robot. Presets by name; any field can be overridden."""

from __future__ import annotations

from typing import Annotated, Any, Literal

import msgspec
from msgspec import Meta, Struct

Frac = Annotated[float, Meta(ge=-0.5, le=0.5)]  # a relative error, e.g. 0.003 = +0.3 %
NonNeg = Annotated[float, Meta(ge=0.0, le=1e3)]
Prob = Annotated[float, Meta(ge=0.0, le=1.0)]


class Fault(Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """A sensor fault the simulated world injects from `start` for `duration` seconds of stack time.

    gyro_dead: no IMU sample; encoder_frozen: the left encoder count holds;
    duplicate: every encoder and IMU sample and every VPS fix is sent twice;
    future_stamp: samples and fixes are stamped far ahead (1000 s). The world model applies them.
    """

    kind: Literal["gyro_dead", "encoder_frozen", "duplicate", "future_stamp"]
    start: NonNeg  # [s]
    duration: Annotated[float, Meta(gt=0.0, le=1e5)]  # [s]


class Scenario(Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """Every error source of the simulated robot and camera (defaults: `default`)."""

    wheel_radius_err_left: Frac = 0.003  # true left radius vs nominal (+0.3 %)
    wheel_radius_err_right: Frac = -0.003  # true right radius vs nominal (-0.3 %)
    track_width_err: Frac = 0.02  # true track width vs nominal (+2 %)
    slip_sigma: Frac = 0.01  # multiplicative noise on each wheel's travel per step, 1 sigma
    load_radius_err: Frac = 0.0  # radius change with payload (tyres compress), both wheels: the mean of the varying model below
    load_payload: tuple[tuple[NonNeg, Annotated[float, Meta(ge=-1e3, le=1e3)]], ...] = ()  # (from t [s], payload [kg] above nominal)
    load_radius_per_kg: Annotated[float, Meta(ge=-0.1, le=0.1)] = 0.0  # [1/kg] relative radius change per kg of payload
    load_radius_per_accel: Annotated[float, Meta(ge=-0.1, le=0.1)] = 0.0  # [s^2/m] both wheels, per m/s^2 forward accel
    load_radius_per_lateral: Annotated[float, Meta(ge=-0.1, le=0.1)] = 0.0  # [s^2/m] outer wheel per m/s^2 centripetal (inner: -)
    ticks_per_rev: Annotated[int, Meta(ge=1, le=1_000_000)] = 360  # encoder resolution
    motor_lag: NonNeg = 0.05  # [s] first-order time constant
    motor_deadband: NonNeg = 0.5  # [rad/s] commands below this do not turn the wheel
    motor_max: Annotated[float, Meta(gt=0.0, le=1e3)] = 10.0  # [rad/s] saturation
    gyro_bias_dps: Annotated[float, Meta(ge=-100, le=100)] = 0.5  # [deg/s]
    gyro_noise_dps: NonNeg = 0.3  # [deg/s] white noise, 1 sigma per sample
    gyro_scale_err: Frac = 0.01  # relative scale error
    accel_bias: Annotated[float, Meta(ge=-10, le=10)] = 0.02  # [m/s^2]
    accel_noise: NonNeg = 0.05  # [m/s^2] 1 sigma
    compass_noise_deg: NonNeg = 3.0  # [deg] 1 sigma
    compass_disturbance_deg: Annotated[float, Meta(ge=-180, le=180)] = 0.0  # [deg] fixed offset near a spot
    compass_disturbance_x: float = 0.5  # [m] centre of the disturbed spot
    compass_disturbance_y: float = 0.5  # [m]
    compass_disturbance_radius: NonNeg = 0.3  # [m]
    vps_rate_hz: Annotated[float, Meta(gt=0.0, le=1000)] = 10.0  # [Hz] fixes captured
    vps_latency: NonNeg = 0.3  # [s] capture -> delivery, mean
    vps_jitter: NonNeg = 0.03  # [s] uniform +/- around the mean
    vps_noise_xy: NonNeg = 0.02  # [m] 1 sigma per axis
    vps_noise_theta_deg: NonNeg = 2.0  # [deg] 1 sigma
    vps_drop: Prob = 0.10  # probability a fix is lost
    vps_outlier: Prob = 0.01  # probability a fix is displaced
    vps_outlier_dist: NonNeg = 0.5  # [m] displacement of an outlier
    vps_outage_start: NonNeg | None = None  # [s] stack time an outage starts (None: no outage)
    vps_outage_duration: NonNeg = 0.0  # [s]
    sensor_rate_hz: Annotated[float, Meta(ge=1.0, le=2000.0)] = 100.0  # [Hz] encoders, imu, clock, truth
    compass_rate_hz: Annotated[float, Meta(gt=0.0, le=1000.0)] = 10.0  # [Hz]
    faults: tuple[Fault, ...] = ()  # scheduled sensor faults, e.g. [{kind = "gyro_dead", start = 10.0, duration = 5.0}]


PRESETS: dict[str, Scenario] = {
    "default": Scenario(),
    "coarse": Scenario(ticks_per_rev=16),
    "harsh": Scenario(
        wheel_radius_err_left=0.01,
        wheel_radius_err_right=-0.01,
        track_width_err=0.04,
        slip_sigma=0.03,
        load_radius_err=-0.005,
        load_payload=((10.0, 0.5), (20.0, 0.0), (30.0, -0.5), (40.0, 0.0)),
        load_radius_per_kg=-0.004,
        load_radius_per_accel=-0.002,
        load_radius_per_lateral=-0.003,
        ticks_per_rev=16,
        motor_lag=0.08,
        motor_deadband=1.0,
        gyro_bias_dps=1.0,
        gyro_noise_dps=0.5,
        gyro_scale_err=0.02,
        accel_bias=0.05,
        accel_noise=0.1,
        compass_noise_deg=5.0,
        compass_disturbance_deg=10.0,
        vps_rate_hz=5.0,
        vps_latency=0.5,
        vps_jitter=0.1,
        vps_noise_xy=0.03,
        vps_noise_theta_deg=3.0,
        vps_drop=0.20,
        vps_outlier=0.02,
        vps_outage_start=20.0,
        vps_outage_duration=10.0,
    ),
}


def scenario(name: str, overrides: dict[str, Any] | None = None) -> Scenario:
    """A preset by name, with field overrides; ValueError names a bad one."""
    if name not in PRESETS:
        raise ValueError(f"unknown scenario {name!r}; choose one of {', '.join(PRESETS)}")
    if not overrides:
        return PRESETS[name]
    merged = {**msgspec.structs.asdict(PRESETS[name]), **overrides}
    return msgspec.convert(merged, Scenario)


# The reference trials of shared/spec/scenarios.md, in the map frame, from (0, 0, 0).
PATH = ((1.0, 0.0), (1.0, 1.0))  # [m] the path trial
SQUARE = ((1.0, 0.0), (1.0, 1.0), (0.0, 1.0), (0.0, 0.0))  # [m] the square trial, one lap
HEADINGS = (5.0, 30.0, 90.0, -90.0, 180.0, -135.0)  # [deg] the turn sweep's targets
