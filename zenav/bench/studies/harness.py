"""One offline trial: the world model's robot under a controller at the sensor rate, every stream recorded.

    trial = Trial(RobotConfig(), scenario, seed=1)
    trial.run(lambda tr: tr.bot.wheels(0.2, 0.0), duration=5.0)  # wheel commands [rad/s], None to stop
    trial.streams.truth, .odom, .imu, .compass, .encoders, .fixes

Each sample is what the sim and vps services would publish at that t: the truth, the
IMU, the compass on its own schedule, the encoders turned into odometry by the
odometry service's pure core, and the VPS fixes with their arrival times, all under
the scenario's scheduled faults. Pure and seeded: time is steps / sensor rate.
"""

from __future__ import annotations

import bisect
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import msgspec

from zenav.common import messages as m
from zenav.common.config import RobotConfig, Settings
from zenav.common.scenarios import Scenario
from zenav.services.odometry import odometry as od
from zenav.services.odometry.service import OdometryConfig, params
from zenav.world import faults, sensors
from zenav.world.bodies import Disc
from zenav.world.sim import SimRobot
from zenav.world.vps import Camera, make_rng

Command = tuple[float, float]  # [rad/s] wheel commands (left, right)
BODY_RADIUS = 0.1  # [m] the robot's footprint among `others` ([sim] body_radius's default)


def arrival(fix: tuple[float, m.VpsPose]) -> float:
    """The arrival time [s] of a recorded fix."""
    return fix[0]


def odometry_config(**overrides: object) -> OdometryConfig:
    """The [odometry] section with overrides (e.g. heading_source="encoders")."""
    return Settings.load(None, odometry=overrides).section("odometry", OdometryConfig)


@dataclass
class Streams:
    """What one trial recorded, each in time order."""

    truth: list[m.Truth] = field(default_factory=list)
    odom: list[m.Odom] = field(default_factory=list)
    imu: list[m.Imu] = field(default_factory=list)
    compass: list[m.Compass] = field(default_factory=list)
    encoders: list[m.Encoders] = field(default_factory=list)  # the counts odometry is computed from (a peer estimator's input)
    fixes: list[tuple[float, m.VpsPose]] = field(default_factory=list)  # (arrival time [s], fix), in arrival order


class Trial:
    """A SimRobot at (x, y, theta) with its odometry and camera; the first sample is taken at t = 0."""

    def __init__(
        self,
        robot: RobotConfig,
        scenario: Scenario,
        seed: int,
        odometry: OdometryConfig | None = None,  # None: encoders only
        camera: bool = True,  # capture VPS fixes
        x: float = 0.0,  # [m]
        y: float = 0.0,  # [m]
        theta: float = 0.0,  # [rad]
        others: Mapping[str, Disc] | None = None,  # other robots' bodies on the field, standing (the robot's own: 0.1 m)
    ) -> None:
        if robot.ticks_per_rev is None:  # the encoders are known: take the scenario's
            robot = msgspec.structs.replace(robot, ticks_per_rev=scenario.ticks_per_rev)
        self.scenario = scenario
        self.bot = SimRobot(robot, scenario, seed, x, y, theta, body_radius=BODY_RADIUS)
        self.others = others
        self.rate = scenario.sensor_rate_hz  # [Hz]
        self.dt = 1.0 / self.rate  # [s]
        self.params = params(robot, odometry or odometry_config(heading_source="encoders"))
        self.odometry = od.OdometryState()
        self.camera = Camera(scenario, make_rng(seed)) if camera else None
        self.hold = faults.EncoderHold()
        self.steps = 0
        self.streams = Streams()
        self.odom: m.Odom | None = None  # the newest odometry pose
        self.cmd = (0.0, 0.0)  # [rad/s] the wheel commands of the newest step
        self._sample()

    @property
    def t(self) -> float:
        """Time [s] of the newest sample."""
        return self.steps / self.rate

    def step(self, left: float, right: float) -> None:
        """One sensor period under wheel commands [rad/s], then the sample at its end."""
        self.cmd = (left, right)
        self.bot.step(left, right, self.dt, self.others)
        self.steps += 1
        self._sample()

    def run(self, controller: Callable[[Trial], Command | None], duration: float) -> bool:
        """Step under the controller's commands (asked at each sample) for at most `duration` [s];
        True when it stopped (returned None) first."""
        for _ in range(round(duration * self.rate)):
            cmd = controller(self)
            if cmd is None:
                return True
            self.step(*cmd)
        return False

    def _sample(self) -> None:
        t, s, out, sc = self.t, self.bot.state, self.streams, self.scenario
        fx = faults.at(sc, t)
        truth = m.Truth(t=t, x=s.x, y=s.y, theta=s.theta, v=s.v, omega=s.omega)
        out.truth.append(truth)
        gyro_z, accel_x, accel_y = self.bot.imu()
        if fx.imu:
            out.imu.append(m.Imu(t=fx.stamp, gyro_z=gyro_z, accel_x=accel_x, accel_y=accel_y))
            for _ in range(fx.copies):
                self.odometry, _ = od.on_imu(self.odometry, self.params, fx.stamp, gyro_z, accel_y)
        if sensors.due(self.steps, sc.compass_rate_hz, self.rate):
            heading = self.bot.compass()
            out.compass.append(m.Compass(t=fx.stamp, heading=heading))
            self.odometry, _ = od.on_compass(self.odometry, fx.stamp, heading)
        left, right = self.bot.encoders()
        left = self.hold.apply(fx, left)
        out.encoders.append(m.Encoders(t=fx.stamp, left=left, right=right))
        for _ in range(fx.copies):
            self.odometry, odom, event = od.update(self.odometry, self.params, left, right, fx.stamp, self.cmd)
            if event == od.BASELINE:  # the odom frame's origin, so that every stream starts at t = 0
                odom = m.Odom(t=fx.stamp, x=0.0, y=0.0, theta=0.0, v=0.0, omega=0.0)
            if odom is not None:
                self.odom = odom
                out.odom.append(odom)
        if self.camera is not None and (d := self.camera.capture(truth)) is not None:
            fix_fx = faults.at(sc, d.fix.t)
            fix = msgspec.structs.replace(d.fix, t=fix_fx.stamp)
            for _ in range(fix_fx.copies):
                bisect.insort(out.fixes, (d.t_delivery, fix), key=arrival)
