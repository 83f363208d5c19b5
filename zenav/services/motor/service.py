"""The motor service: `cmd_vel` to wheel speed commands on `motors/wheels`, with limits and a watchdog."""

from __future__ import annotations

from typing import Annotated

from msgspec import Meta, Struct

from zenav.common import messages as m
from zenav.common.bus import Bus
from zenav.common.clock import Clock
from zenav.common.config import Settings
from zenav.common.runtime import Service, on_liveliness, publish, subscribe, timer
from zenav.services.motor import kinematics as kin

ZERO = (0.0, 0.0)


class MotorConfig(Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """[motor]: wheel limits and the command watchdog."""

    max_wheel_accel: Annotated[float, Meta(gt=0.0, le=1e4)] = 100.0  # [rad/s^2] per wheel (0 -> 10 rad/s in 0.1 s)
    max_accel_dt: Annotated[float, Meta(gt=0.0, le=10.0)] = 0.1  # [s] longest elapsed time one acceleration step covers
    deadband: Annotated[float, Meta(ge=0.0, le=100.0)] = 0.5  # [rad/s] smaller non-zero commands are raised to it
    watchdog: Annotated[float, Meta(gt=0.0, le=60.0)] = 0.5  # [s] no cmd_vel this long: stop; older ones are stale
    watchdog_period: Annotated[float, Meta(gt=0.0, le=1.0)] = 0.05  # [s] how often the watchdog looks (20 Hz)


class Motor(Service):
    """Velocity commands to wheel speeds: inverse kinematics, saturation, acceleration limit, deadband, watchdog."""

    name = "motor"
    config_type = MotorConfig
    cfg: MotorConfig

    def __init__(self, settings: Settings, bus: Bus, clock: Clock) -> None:
        super().__init__(settings, bus, clock)
        robot = settings.robot
        self.wheels = kin.Limits(
            radius=robot.wheel_radius,
            track=robot.track_width,
            max_speed=robot.max_wheel_speed,
            max_accel=self.cfg.max_wheel_accel,
            deadband=self.cfg.deadband,
        )
        self.watchdog_period = self.cfg.watchdog_period  # read by @timer
        self.ramp = ZERO  # [rad/s] (left, right) of the last output before deadband compensation
        self.last_out_t: float | None = None  # [s] clock time of the last output
        self.last_cmd_t = 0.0  # [s] clock time the last command was accepted
        self.count("watchdog_stops", 0)
        self.count("navigator_lost_stops", 0)
        self.wheels_alive: dict[str, bool] = {}  # "sim" / "driver" -> its token is up (what turns the wheels)

    def on_clock_reset(self) -> None:
        # Times of the old clock would make the elapsed times negative.
        self.last_out_t = None
        self.last_cmd_t = self.clock.now()

    def _output(self, t: float, ramp: tuple[float, float], wheels: tuple[float, float], now: float) -> m.Wheels:
        self.ramp, self.last_out_t = ramp, now
        return m.Wheels(t=t, left=wheels[0], right=wheels[1])

    @subscribe("cmd_vel", latest=True)  # a command that a newer one followed is not run late
    @publish("motors/wheels")
    def on_cmd_vel(self, msg: m.CmdVel) -> m.Wheels | None:
        """One velocity command: the wheel commands after limits, stamped with the command's t."""
        now = self.clock.now()
        if msg.t > 0.0 and now - msg.t > self.cfg.watchdog:  # t == 0: "now" (no stack clock)
            self.count("dropped_stale")
            self.warn("stale", f"dropped cmd_vel {now - msg.t:.3f} s old")
            return None
        dt = self.cfg.max_accel_dt if self.last_out_t is None else now - self.last_out_t
        dt = min(max(dt, 0.0), self.cfg.max_accel_dt)
        self.last_cmd_t = now
        return self._output(msg.t, *kin.wheel_command(msg.v, msg.omega, self.ramp, dt, self.wheels), now)

    @timer("watchdog_period")
    @publish("motors/wheels")
    def check_watchdog(self, now: float) -> m.Wheels | None:
        """Stop the wheels once when moving and no command came within the watchdog time."""
        if self.ramp == ZERO or now - self.last_cmd_t <= self.cfg.watchdog:
            return None
        self.count("watchdog_stops")
        self.warn("watchdog", f"no cmd_vel for {now - self.last_cmd_t:.2f} s: wheels stopped")
        return self._output(now, ZERO, ZERO, now)

    @on_liveliness("navigator")
    @publish("motors/wheels")
    def navigator_presence(self, alive: bool) -> m.Wheels | None:
        """The navigator's process is gone (its token went with its socket): stop now, not at the watchdog."""
        if alive or self.ramp == ZERO:
            return None
        self.count("navigator_lost_stops")
        self.warn("navigator_lost", "navigator gone: wheels stopped")
        now = self.clock.now()
        return self._output(now, ZERO, ZERO, now)

    @on_liveliness("sim")
    def sim_presence(self, alive: bool) -> None:
        self._wheels_presence("sim", alive)

    @on_liveliness("driver")
    def driver_presence(self, alive: bool) -> None:
        self._wheels_presence("driver", alive)

    def _wheels_presence(self, name: str, alive: bool) -> None:
        """Error while what turns the wheels (the sim or the motor board's driver), seen before, is gone."""
        self.wheels_alive[name] = alive
        if any(self.wheels_alive.values()):
            self.set_status("ok")
        else:
            self.set_status("error", f"{name} gone: wheel commands reach no wheels (is the sim or the driver running?)")

    def on_stop(self) -> None:
        now = self.clock.now()
        self.publish("motors/wheels", self._output(now, ZERO, ZERO, now))
