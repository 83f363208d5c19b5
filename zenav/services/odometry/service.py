"""The odometry service: wheel encoders (and the chosen heading sensor) to `odom`."""

from __future__ import annotations

from collections.abc import Callable
from typing import Annotated, Any, Literal

from msgspec import Meta, Struct

from zenav.common import keys
from zenav.common import messages as m
from zenav.common.bus import Bus
from zenav.common.clock import Clock
from zenav.common.config import RobotConfig, Settings
from zenav.common.runtime import Service, publish, subscribe, timer
from zenav.services.odometry import heading as hd
from zenav.services.odometry import odometry as od

NonNeg = Annotated[float, Meta(ge=0.0, le=1e3)]
Positive = Annotated[float, Meta(gt=0.0, le=1e3)]

ENCODERS_SILENT = 1.0  # [s] encoders heard before and silent this long: status error (no odometry)
# The sensor topics each heading source listens to, besides the encoders.
SOURCE_TOPICS = {"encoders": (), "gyro": ("sensors/imu",), "compass": ("sensors/compass",), "blend": ("sensors/imu",)}


class OdometryConfig(Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """[odometry]: integrator, heading source and noise model."""

    integrator: Literal["euler", "midpoint", "rk4", "arc"] = "arc"  # pose integrator of one step
    heading_source: Literal["encoders", "gyro", "compass", "blend"] = "compass"  # where heading changes come from
    noise_k_left: Annotated[float, Meta(ge=0.0, le=1.0)] = 1e-4  # [m] variance of left travel per metre (m^2/m)
    noise_k_right: Annotated[float, Meta(ge=0.0, le=1.0)] = 1e-4  # [m] variance of right travel per metre
    blend_encoders: NonNeg = 1.0  # blend: weight of the encoders' heading change [-]
    blend_gyro: NonNeg = 3.0  # blend: weight of the gyro's heading change [-]
    blend_accel: NonNeg = 0.0  # blend: weight of the accelerometer's (a_y / v) heading change [-]
    gyro_var_rate: NonNeg = 5e-4  # [rad^2/s] heading variance the gyro adds per second
    accel_var_rate: NonNeg = 1e-2  # [rad^2/s] heading variance the accelerometer adds per second
    compass_sigma: Annotated[float, Meta(gt=0.0, le=3.2)] = 0.05  # [rad] 1 sigma of one compass heading
    compass_gain: Annotated[float, Meta(gt=0.0, le=1.0)] = 0.1  # fraction of the way a compass sample pulls the heading
    reset_factor: Annotated[float, Meta(ge=1.0, le=1e3)] = 3.0  # a wheel faster than this x max_wheel_speed: reset [-]
    still_time: Positive = 0.5  # [s] no encoder tick for this long: standing still (gyro bias learning)
    still_rate: Positive = 0.02  # [rad/s] a gyro rate above this (bias removed) is motion, not bias
    gyro_bias_time: Positive = 5.0  # [s] time constant of the gyro bias average
    accel_min_speed: Positive = 0.05  # [m/s] below this speed a_y / v is not used
    imu_timeout: Positive = 0.1  # [s] IMU silent this long is missing: heading from the encoders
    compass_timeout: Positive = 0.5  # [s] compass silent this long is missing (status degraded)
    stall_speed: NonNeg = 2.0  # [rad/s] a wheel commanded faster than this whose encoder shows nothing is silent
    stall_ticks: Positive = 5.0  # [ticks] ... once the command should have turned it this far
    stall_time: Positive = 0.3  # [s] ... and at least this long
    subtick: bool = True  # each wheel's position within its tick from the tick timing; false: whole ticks
    motor_lag: NonNeg = 0.05  # [s] the motors' time constant: how a wheel's speed follows its command (subtick)


def params(robot: RobotConfig, c: OdometryConfig) -> od.Params:
    """The odometry's parameters from the nominal robot and the [odometry] section."""
    heading = hd.HeadingParams(
        source=c.heading_source,
        weights=(c.blend_encoders, c.blend_gyro, c.blend_accel),
        gyro_var_rate=c.gyro_var_rate,
        accel_var_rate=c.accel_var_rate,
        compass_var=c.compass_sigma**2,
        compass_gain=c.compass_gain,
        still_time=c.still_time,
        still_rate=c.still_rate,
        bias_time=c.gyro_bias_time,
        accel_min_speed=c.accel_min_speed,
        imu_timeout=c.imu_timeout,
        compass_timeout=c.compass_timeout,
    )
    stall_limits = (c.stall_speed, c.stall_ticks, c.stall_time)
    noise = (c.noise_k_left, c.noise_k_right)
    return od.make_params(robot, c.integrator, *noise, c.reset_factor, heading, stall_limits, c.subtick, c.motor_lag)


class Odometry(Service):
    """Wheel encoders (and a gyro or compass if configured) to `odom`, one pose per encoder sample."""

    name = "odometry"
    config_type = OdometryConfig
    cfg: OdometryConfig
    health_period = 0.5  # [s] how often a silent encoder stream is looked for

    def __init__(self, settings: Settings, bus: Bus, clock: Clock) -> None:
        super().__init__(settings, bus, clock)
        self.params = params(settings.robot, self.cfg)
        self.state = od.OdometryState()

    def on_start(self) -> None:
        # Heading sensors are subscribed only when the configured source reads them.
        handlers: dict[str, Callable[[Any], Any]] = {"sensors/imu": self.on_imu, "sensors/compass": self.on_compass}
        for suffix in SOURCE_TOPICS[self.cfg.heading_source]:
            self.subscribe(suffix, keys.TOPICS[suffix], handlers[suffix])

    def on_clock_reset(self) -> None:
        # The sim restarted: its time and encoders start again, and so does the odom frame.
        self.state = od.OdometryState()

    @subscribe("sensors/encoders")
    @publish("odom")
    def on_encoders(self, msg: m.Encoders) -> m.Odom | None:
        """One encoder sample: an odom pose, or None (baseline, dropped, reset). A wheel the sample says was
        commanded (`cmd_left`, `cmd_right`) and whose count stays still is silent."""
        was = self.state.watch.silent
        cmd = (msg.cmd_left, msg.cmd_right)
        self.state, odom, event = od.update(self.state, self.params, msg.left, msg.right, msg.t, cmd)
        self._silence(was, msg.t, cmd)
        if event == od.STALE:
            self.count("dropped_stale")
        elif event == od.RESET:
            self.count("encoder_resets")
            self.warn("reset", f"encoder jump at t={msg.t:.3f} (ticks {msg.left}, {msg.right}): new baseline")
        elif event == od.FALLBACK:
            self.count("heading_fallback")
            self.set_status("degraded", f"no {self.cfg.heading_source} data: heading from the encoders")
        elif event == od.OK and not any(self.state.watch.silent):
            self.set_status("ok")
        return odom

    @timer("health_period")
    def check_health(self, now: float) -> None:
        """Error while the encoder stream, heard before, is silent: no odom goes out (ok again with the next sample)."""
        last = self.state.t
        if last is not None and now - last > ENCODERS_SILENT:
            self.set_status("error", f"no encoder sample for {now - last:.1f} s: no odometry (is the sim or driver running?)")

    def _silence(self, was: tuple[bool, bool], t: float, cmds: tuple[float, float]) -> None:
        """Count, log and report each wheel whose encoder went silent while commanded `cmds` (`was`: before this sample)."""
        silent = self.state.watch.silent
        for name, before, now, cmd in zip(("left", "right"), was, silent, cmds):
            if now and not before:
                self.count("encoder_silent")
                self.warn(f"silent_{name}", f"{name} encoder shows no motion at t={t:.2f} while commanded {cmd:.1f} rad/s")
        if any(silent):
            wheels = " and ".join(n for n, s in zip(("left", "right"), silent) if s)
            self.set_status("degraded", f"{wheels} encoder silent while commanded: frozen encoder or stalled wheel")

    def on_imu(self, msg: m.Imu) -> None:
        """One IMU sample (gyro and blend sources)."""
        self.state, event = od.on_imu(self.state, self.params, msg.t, msg.gyro_z, msg.accel_y)
        if event == od.STALE:
            self.count("dropped_stale")

    def on_compass(self, msg: m.Compass) -> None:
        """One compass heading (compass source)."""
        self.state, event = od.on_compass(self.state, msg.t, msg.heading)
        if event == od.STALE:
            self.count("dropped_stale")
