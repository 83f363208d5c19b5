"""The sim service: steps the world model (zenav.world) at the sensor rate, publishes clock, truth and sensors,
and where its robot's body is on the field, which the other robots' sims keep out of."""

from __future__ import annotations

import math
import time
from functools import partial
from typing import TYPE_CHECKING, Annotated

from msgspec import Meta, Struct

from zenav.common import codec, extras, keys
from zenav.common import messages as m
from zenav.common.bus import Bus, Query
from zenav.common.clock import Clock, ScaledWallClock
from zenav.common.config import Camera, Settings
from zenav.common.others import Others
from zenav.common.runtime import Service, on_liveliness, query, subscribe, timer
from zenav.world import faults, sensors
from zenav.world.bodies import Chassis, Disc, Walls
from zenav.world.sim import SimRobot

if TYPE_CHECKING:  # the camera renders with OpenCV: imported when [sim] camera is on
    from zenav.services.sim.camera import Shutter

CHASSIS = (1.6, 1.2)  # the default chassis's length and width, per body_radius: a 4:3 rectangle whose corners touch the disc


class SimConfig(Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """The [sim] section."""

    rtf: Annotated[float, Meta(ge=0.1, le=100.0)] = 1.0  # realtime factor: sim seconds per wall second
    x0: Annotated[float, Meta(ge=-1e3, le=1e3)] = 0.0  # [m] initial x, map frame
    y0: Annotated[float, Meta(ge=-1e3, le=1e3)] = 0.0  # [m] initial y, map frame
    theta0: Annotated[float, Meta(ge=-math.pi, le=math.pi)] = 0.0  # [rad] initial heading
    command_timeout: Annotated[float, Meta(gt=0.0, le=60.0)] = 0.5  # [s] sim time without motors/wheels before the wheels stop
    max_burst: Annotated[int, Meta(ge=1, le=10_000)] = 50  # [steps] most steps one tick catches up before resyncing
    encoder_start: m.Ticks = 0  # [ticks] count both encoders read at start (to exercise the int32 wrap)
    camera: bool = False  # render the overhead camera's frames ([camera]) on zenav/field/camera/frame
    # render the robot's own camera's frames ([onboard_camera]) on camera/onboard/frame; None: when [vps] source or also
    # has "onboard"
    onboard_camera: bool | None = None
    # [Hz] of sim time: clock ticks (at most one a step); at rtf 1 a tick at least every SimClock's 0.25 s of extrapolation
    clock_rate_hz: Annotated[float, Meta(ge=5.0, le=2000.0)] = 20.0
    # [m] the robot's footprint, a disc other simulated robots on the field keep out of (and it out of theirs); 0: none
    body_radius: Annotated[float, Meta(ge=0.0, le=10.0)] = 0.1
    walls: bool = True  # the [field] area's edges are walls the footprint stays inside (with [field] enabled)
    # [m] the chassis, a rectangle centred on the wheels' axle, that meets the walls (and squares up against one):
    # by default CHASSIS times body_radius (a rectangle inside the disc); both 0: the disc meets them
    body_length: Annotated[float, Meta(ge=0.0, le=10.0)] | None = None
    body_width: Annotated[float, Meta(ge=0.0, le=10.0)] | None = None

    def __post_init__(self) -> None:
        if self.camera:  # at start, in one line, rather than when the first frame is due
            extras.check("cv2", "the sim's camera ([sim] camera = true)")
        if self.onboard_camera:
            extras.check("cv2", "the sim's onboard camera ([sim] onboard_camera = true)")
        length, width = self.chassis()
        if (length > 0.0) != (width > 0.0):
            raise ValueError(
                f"body_length {length:g} and body_width {width:g} m: both > 0 (a chassis against the walls) or both 0 (the disc)"
            )

    def chassis(self) -> tuple[float, float]:
        """[m] (length, width) of the chassis against the walls, the defaults drawn from body_radius; (0, 0): the disc."""
        length = CHASSIS[0] * self.body_radius if self.body_length is None else self.body_length
        return length, CHASSIS[1] * self.body_radius if self.body_width is None else self.body_width


OVERRUN_HOLD = 5.0  # [s] of the scheduling clock a fall behind keeps the status degraded
BODY_RATE_HZ = 20.0  # [Hz] of sim time: how often the sim tells the field where its robot's body is
BODY_KEPT = 1.0  # [s] of sim time another robot's body is kept after its last report (its sim stopped: gone)


class Sim(Service):
    """The simulated world: the robot of the scenario, its sensors, and the stack clock."""

    name = "sim"
    config_type = SimConfig
    health_period = 0.5  # [s] how often the status is brought up to date

    def __init__(self, settings: Settings, bus: Bus, clock: Clock) -> None:
        super().__init__(settings, bus, clock)
        self.scen = settings.scenario
        self.rate = self.scen.sensor_rate_hz  # [Hz] physics steps and sensor samples
        self.step_period = 1.0 / self.rate  # [s] of the scheduling clock: one physics step
        self.tick_period = self.step_period / 2  # [s] the tick timer's: a step, and half a step later what follows it
        c = self.cfg
        f = settings.field
        walls = Walls(f.x_min, f.x_max, f.y_min, f.y_max) if c.walls and f.enabled else None
        seed = settings.deployment.seed
        length, width = c.chassis()
        chassis = Chassis(length, width) if length > 0.0 else None
        self.bot = SimRobot(
            settings.robot, self.scen, seed, c.x0, c.y0, c.theta0, c.encoder_start, c.body_radius, walls, chassis, f.shapes()
        )
        self.others: Others[Disc] = Others(self.robot, BODY_KEPT)  # the bodies it steps among, by sim time heard
        self.steps = 0  # steps taken: sim time is steps / rate, never read from the wall
        self.base = 0.0  # [s] scheduling-clock time of step 0 (moves forward on a resync)
        self.cmd = (0.0, 0.0)  # [rad/s] wheel commands (left, right)
        self.cmd_t: float | None = None  # [s] sim time the command arrived; None: wheels stopped
        self.hold = faults.EncoderHold()  # the left count while an encoder_frozen fault lasts
        self.shutter: Shutter | None = None
        if c.camera:
            from zenav.services.sim.camera import FieldCamera, Shutter

            cam = settings.section("camera", Camera)
            hidden = partial(faults.vps_outage, self.scen)  # the scenario's VPS outage hides the robot from the camera
            self.shutter = Shutter(FieldCamera(cam, settings.deployment.seed, cam.robots.get(self.robot), hidden), self._send_frame)
        self.onboard: Shutter | None = None
        vps = settings.sections.get("vps", {})
        if c.onboard_camera or (c.onboard_camera is None and "onboard" in (vps.get("source"), *vps.get("also", ()))):
            from zenav.services.sim.camera import Shutter
            from zenav.services.sim.onboard import OnboardFrames

            self.onboard = Shutter(OnboardFrames(settings), self._send_onboard)
        self.count("overruns", 0)
        self.count("command_timeouts", 0)
        self.count("contacts", 0)
        self._behind: tuple[float, str] | None = None  # (scheduling-clock time, why) of the last fall behind
        self._after: list[tuple[str, m.Clock | m.Truth | m.Body]] = []  # the last step's clock tick and truth, sent on the next tick

    @classmethod
    def make_clock(cls, settings: Settings) -> Clock:
        """The sim owns time: wall time scaled by the realtime factor."""
        return ScaledWallClock(settings.section(cls.name, SimConfig).rtf)

    def _send_frame(self, frame: m.CameraFrame) -> None:
        """Publish a frame on the field's key (on the shutter's thread)."""
        self.bus.publish(keys.field_key("camera/frame"), codec.encode(frame))

    def _send_onboard(self, frame: m.CameraFrame) -> None:
        """Publish a frame of the robot's own camera (on its shutter's thread)."""
        self.bus.publish(self.key("camera/onboard/frame"), codec.encode(frame))

    def on_stop(self) -> None:
        for shutter in (self.shutter, self.onboard):
            if shutter is not None:
                shutter.close()

    def on_start(self) -> None:
        self.base = self.clock.now()
        if self.cfg.body_radius > 0.0:
            self.subscribe("sim/body", m.Body, self.on_body, other_clock=True)  # each sim stamps on its own

    def on_body(self, msg: m.Body) -> None:
        """Another robot's body on the field (this robot's own comes back too: not kept)."""
        self.others.heard(msg.robot, self.t, Disc(msg.x, msg.y, msg.radius))

    def _bodies(self) -> dict[str, Disc]:
        """The other robots' bodies heard within BODY_KEPT."""
        return self.others.at(self.t)

    @property
    def t(self) -> float:
        """Sim time [s] of the newest step."""
        return self.steps / self.rate

    @subscribe("motors/wheels")
    def on_wheels(self, msg: m.Wheels) -> None:
        self.cmd, self.cmd_t = (msg.left, msg.right), self.t

    @on_liveliness("motor")
    def motor_presence(self, alive: bool) -> None:
        """A motor process that dies takes its token with it: stop the wheels at once."""
        if not alive and self.cmd_t is not None:
            self.cmd, self.cmd_t = (0.0, 0.0), None
            self.count("motor_lost_stops")
            self.warn("motor_lost", "motor service gone: wheels stopped")

    @query("sim/reset")
    def reset(self, req: m.SimReset, q: Query) -> m.PoseStamped:
        if req.seed is not None:
            self.bot.reseed(req.seed)
        s = self.bot.teleport(req.x, req.y, req.theta)
        self.cmd, self.cmd_t = (0.0, 0.0), None
        self.log.info("reset to (%.3f, %.3f, %.3f)%s", s.x, s.y, s.theta, f" seed {req.seed}" if req.seed is not None else "")
        return m.PoseStamped(t=self.t, x=s.x, y=s.y, theta=s.theta)

    @timer("tick_period")
    def tick(self, now: float) -> None:
        """Send what the last step left for later, then take every step owed up to `now` of the scheduling clock,
        at most max_burst."""
        self.send_after()
        owed = math.floor((now - self.base) * self.rate + 1e-6) - self.steps
        if owed > self.cfg.max_burst:
            # Too far behind (host too slow for the rtf, or stalled): drop the lost time.
            self.count("overruns")
            why = f"sim fell {owed} steps behind; running {self.cfg.max_burst} and resyncing"
            self.warn("overrun", why)
            self._behind = (now, f"{why} (host too slow for rtf {self.cfg.rtf:g}, or stalled)")
            self.check_health(now)
            owed = self.cfg.max_burst
            self.base = now - (self.steps + owed) / self.rate
        for k in range(owed):
            if k:  # catching up: a step's clock tick goes out before the next step's sensors, which it admits
                self.send_after()
            self.advance()

    def send_after(self) -> None:
        """Send the clock tick and truth the last step left for later."""
        after, self._after = self._after, []
        for suffix, msg in after:
            self.publish(suffix, msg)

    def advance(self) -> None:
        """One physics step of 1/rate seconds, then publish what the sensors saw (the step's clock tick and truth
        go out on the next tick, half a step later)."""
        t = (self.steps + 1) / self.rate
        if self.cmd_t is not None and t - self.cmd_t > self.cfg.command_timeout:
            # Like a real motor board: no command for a while, stop the wheels.
            self.cmd, self.cmd_t = (0.0, 0.0), None
            self.count("command_timeouts")
        was = self.bot.met
        s = self.bot.step(*self.cmd, self.step_period, self._bodies())
        self.steps += 1
        for what in self.bot.met:
            if what not in was:  # a contact begins
                self.count("contacts")
                what = what if what.startswith(("wall ", "obstacles[")) else f"robot {what}"
                self.log.info("drove into %s at (%.3f, %.3f): held there, the wheels slipping", what, s.x, s.y)
        fx = faults.at(self.scen, t)
        left, right = self.bot.encoders()
        # With the command the wheels ran at this step: a commanded wheel whose count holds is found by the odometry.
        encoders = m.Encoders(t=fx.stamp, left=self.hold.apply(fx, left), right=right, cmd_left=self.cmd[0], cmd_right=self.cmd[1])
        gyro_z, accel_x, accel_y = self.bot.imu()
        imu = m.Imu(t=fx.stamp, gyro_z=gyro_z, accel_x=accel_x, accel_y=accel_y)
        # The sample's instant on the host, once its sensors are read (as a driver stamps a reading):
        # `clock` and `sim/truth` carry it, and latency is measured from it.
        wall = time.time()
        # The gyro first: the odom sample the encoders become reaches the localizer after it
        # (and the odometry, where it reads the gyro), so the step that sample starts can use it.
        # Sent after the encoders, it would come behind their whole chain in a composed process,
        # whose link is read in order, and the filter would predict every step twice.
        for _ in range(fx.copies):
            if fx.imu:
                self.publish("sensors/imu", imu)
            self.publish("sensors/encoders", encoders)
        # The clock and the truth of the same t, half a step later: sent now, they would wake
        # the processes that follow them (every service, the vps, views) while the sample goes
        # through the control chain, which then waits for a core. They carry `wall`, so their
        # lateness changes no reading of them. The clock ticks at clock_rate_hz (services
        # extrapolate between ticks), from the first step on.
        if sensors.due(self.steps - 1, self.cfg.clock_rate_hz, self.rate):
            self._after.append(("clock", m.Clock(t=t, rtf=self.cfg.rtf, wall=wall, instance=self.instance)))
        truth = m.Truth(t=t, x=s.x, y=s.y, theta=s.theta, v=s.v, omega=s.omega, wall=wall)
        self._after.append(("sim/truth", truth))
        if self.cfg.body_radius > 0.0 and sensors.due(self.steps - 1, BODY_RATE_HZ, self.rate):
            self._after.append(("sim/body", m.Body(t=t, robot=self.robot, x=s.x, y=s.y, radius=self.cfg.body_radius)))
        if sensors.due(self.steps, self.scen.compass_rate_hz, self.rate):
            self.publish("sensors/compass", m.Compass(t=fx.stamp, heading=self.bot.compass()))
        if self.shutter is not None:
            self.shoot(truth, self.shutter, "frames")
        if self.onboard is not None:
            self.shoot(truth, self.onboard, "onboard_frames")

    def shoot(self, truth: m.Truth, shutter: Shutter, what: str) -> None:
        """A camera frame of this step, when one is due (drawn and sent on the shutter's thread); counted as `what`_*."""
        outcome = shutter.take(truth)
        if outcome is not None:
            self.count(f"{what}_{outcome}")
        lost = shutter.camera.lost - self.counters.values.get(f"{what}_lost", 0)
        if lost > 0:  # the camera's drop_rate: lost on the way, as a real link loses frames
            self.count(f"{what}_lost", lost)
        failed = shutter.failed - self.counters.values.get(f"{what}_failed", 0)
        if failed > 0:
            self.count(f"{what}_failed", failed)
            self.warn(what, f"camera frame failed: {shutter.error}")

    @timer("health_period")
    def check_health(self, now: float) -> None:
        """Error while camera frames fail; degraded for a while after the sim fell behind the clock."""
        if self._behind is not None and now - self._behind[0] > OVERRUN_HOLD:
            self._behind = None
        failing = [s for s in (self.shutter, self.onboard) if s is not None and s.error]
        if failing:
            self.set_status("error", f"camera frames fail: {failing[0].error}")
        elif self._behind is not None:
            self.set_status("degraded", self._behind[1])
        else:
            self.set_status("ok")
