"""The motor service: `cmd_vel` to wheel speed commands on `motors/wheels`, with limits, a watchdog and the guard.

The guard (guard.py) is the safety layer under every command source (a goal's, teleop, `drive`, a raw `cmd_vel`):
from the newest `pose`, it slows and then stops the robot before its footprint meets a [field] obstacle, another
robot (their bodies on the field topic `robots`, which this service also sends its own robot's on) or, with
`guard_edges`, the field's edge. It re-checks the command in force on every pose. What it limits is counted
(`guard_slowed`, `guard_stopped`) and said on `motor/guard` when it changes; without a fresh pose it cannot judge, and
passes the commands on, counted (`guard_blind`).
"""

from __future__ import annotations

from typing import Annotated

from msgspec import Meta, Struct

from zenav.common import messages as m
from zenav.common.bus import Bus
from zenav.common.clock import Clock
from zenav.common.config import Settings
from zenav.common.others import Others
from zenav.common.runtime import Service, on_liveliness, publish, subscribe, timer
from zenav.services.motor import kinematics as kin
from zenav.services.motor.guard import Guard, Limit, position_sigma

ZERO = (0.0, 0.0)
BODY_KEPT = 0.5  # [s] another robot's body not heard again for this long is forgotten


class MotorConfig(Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """[motor]: wheel limits and the command watchdog."""

    max_wheel_accel: Annotated[float, Meta(gt=0.0, le=1e4)] = 100.0  # [rad/s^2] per wheel (0 -> 10 rad/s in 0.1 s)
    max_accel_dt: Annotated[float, Meta(gt=0.0, le=10.0)] = 0.1  # [s] longest elapsed time one acceleration step covers
    deadband: Annotated[float, Meta(ge=0.0, le=100.0)] = 0.5  # [rad/s] smaller non-zero commands are raised to it
    watchdog: Annotated[float, Meta(gt=0.0, le=60.0)] = 0.5  # [s] no cmd_vel this long: stop; older ones are stale
    watchdog_period: Annotated[float, Meta(gt=0.0, le=1.0)] = 0.05  # [s] how often the watchdog looks (20 Hz)
    guard: bool = True  # the safety layer: slow near and stop before obstacles, other robots (and edges)
    guard_gap: Annotated[float, Meta(ge=0.0, le=1.0)] = 0.005  # [m] the footprint stops this far before what it would meet ...
    guard_sigmas: Annotated[float, Meta(ge=0.0, le=10.0)] = 2.0  # ... plus this many of the pose's position sigmas
    guard_decel: Annotated[float, Meta(gt=0.0, le=100.0)] = 0.5  # [m/s^2] the speed allowed brakes at this within the room ahead
    guard_edges: bool = False  # also stop before the [field] edge (false: a robot may square up against it)
    guard_pose_age: Annotated[float, Meta(gt=0.0, le=10.0)] = 0.5  # [s] an older pose cannot judge: commands pass, counted
    body_period: Annotated[float, Meta(gt=0.0, le=10.0)] = 0.1  # [s] how often the robot's body goes out on the field topic


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
        area = settings.field
        self.radius = robot.radius
        bounds = (area.x_min, area.y_min, area.x_max, area.y_max) if area.enabled and self.cfg.guard_edges else None
        self.guard = Guard(area.shapes(), robot.radius, self.cfg.guard_gap, self.cfg.guard_decel, bounds)
        self.body_period = self.cfg.body_period  # read by @timer
        self.pose: m.Pose | None = None  # newest
        self.others: Others[tuple[float, float, float]] = Others(self.robot, BODY_KEPT)  # their discs (x, y, radius)
        self.asked: m.CmdVel | None = None  # the command in force, as asked (re-checked on each pose)
        self.limited: tuple[str, bool] = ("", False)  # what the guard holds the command in force back for, and whether to zero
        for name in ("guard_slowed", "guard_stopped", "guard_blind"):
            self.count(name, 0)

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
        self.last_cmd_t = now
        self.asked = msg
        return self._drive(msg, now, self._guarded(msg, now))

    def _drive(self, msg: m.CmdVel, now: float, cmd: Limit) -> m.Wheels:
        dt = self.cfg.max_accel_dt if self.last_out_t is None else now - self.last_out_t
        dt = min(max(dt, 0.0), self.cfg.max_accel_dt)
        return self._output(msg.t, *kin.wheel_command(cmd.v, cmd.omega, self.ramp, dt, self.wheels), now)

    def _guarded(self, msg: m.CmdVel, now: float) -> Limit:
        """The command after the guard; counted and said when it limits."""
        if not self.cfg.guard or msg.v == 0.0:
            return self._say(Limit(msg.v, msg.omega))
        pose = self.pose
        if pose is None or now - pose.t > self.cfg.guard_pose_age:
            self.count("guard_blind")
            self.warn("guard_blind", "no fresh pose: the guard cannot judge the way ahead; commands pass unchecked")
            return self._say(Limit(msg.v, msg.omega))
        doubt = self.cfg.guard_sigmas * position_sigma(pose.cov)
        return self._say(self.guard.limit(msg.v, msg.omega, pose.x, pose.y, pose.theta, self._bodies(now), doubt))

    def _say(self, cmd: Limit) -> Limit:
        if cmd.what:
            self.count("guard_stopped" if cmd.stopped else "guard_slowed")
        if (cmd.what, cmd.stopped) != self.limited:
            self.limited = (cmd.what, cmd.stopped)
            if cmd.what:
                self.warn("guard", f"guard: {'stopped' if cmd.stopped else 'slowed'}: {cmd.reason}")
            self.publish("motor/guard", m.GuardState(t=self.clock.now(), reason=cmd.reason, v=cmd.v, stopped=cmd.stopped))
        return cmd

    def _bodies(self, now: float) -> list[tuple[str, tuple[float, float, float]]]:
        return list(self.others.at(now).items())

    @subscribe("pose", latest=True)
    @publish("motors/wheels")
    def on_pose(self, msg: m.Pose) -> m.Wheels | None:
        """The newest pose: the command in force re-checked (the way ahead shrinks as the robot drives on)."""
        if self.pose is not None and msg.t < self.pose.t:
            return None
        self.pose = msg
        asked, now = self.asked, self.clock.now()
        if not self.cfg.guard or asked is None or asked.v == 0.0 or now - self.last_cmd_t > self.cfg.watchdog:
            return None
        was = self.limited[0]
        cmd = self._guarded(asked, now)
        if not cmd.what and not was:
            return None
        return self._drive(asked, now, cmd)

    def on_body(self, msg: m.Body) -> None:
        """Another robot's body on the field (this robot's own comes back too: not kept)."""
        self.others.heard(msg.robot, self.clock.now(), (msg.x, msg.y, msg.radius))

    def on_start(self) -> None:
        if self.cfg.guard:
            self.subscribe("robots", m.Body, self.on_body, other_clock=True)  # each robot stamps on its own clock

    @timer("body_period")
    @publish("robots")
    def send_body(self, now: float) -> m.Body | None:
        """This robot's body on the field, from the newest pose, for the other robots' guards and navigators."""
        pose = self.pose
        if pose is None or now - pose.t > self.cfg.guard_pose_age:
            return None
        asked = self.asked  # where its navigator drives it, while it does
        way = asked.way if asked is not None and asked.v != 0.0 and now - self.last_cmd_t <= self.cfg.watchdog else ()
        return m.Body(t=pose.t, robot=self.robot, x=pose.x, y=pose.y, radius=self.radius, theta=pose.theta, v=pose.v, way=way)

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
