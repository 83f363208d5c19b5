"""The simulated robot stepped in time: its true body and its sensors, one seeded generator each.

    bot = SimRobot(RobotConfig(), scenario, seed=1)
    bot.drive(0.2, 0.0, 0.01)          # body velocity through the nominal wheel geometry
    bot.step(5.0, 5.0, 0.01)           # or wheel commands [rad/s]
    bot.step(5.0, 5.0, 0.01, {"r2": Disc(0.3, 0.0, 0.1)})  # among other robots' bodies: bot.met names those it met
    SimRobot(RobotConfig(), scenario, seed=1, body_radius=0.1, walls=Walls(-1.0, 3.0, -1.0, 3.0))  # inside the field
    SimRobot(..., chassis=Chassis(0.16, 0.12))  # a rectangle against the walls, that squares up to one
    bot.state.x, bot.encoders(), bot.imu(), bot.compass()

Pure: time comes in as dt. The body's slip and each sensor's noise draw from their own
generator, so reading a sensor (or not) never changes the path the robot takes.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from zenav.common.config import RobotConfig
from zenav.common.field import Shape
from zenav.common.geometry import wrap_angle
from zenav.common.scenarios import Scenario
from zenav.world import robot as body
from zenav.world import sensors
from zenav.world.bodies import Chassis, Disc, Walls, block, chassis_inside, chassis_travel

# Seed streams, mixed with the seed (numpy SeedSequence entropy words).
MOTION_STREAM = 0x4D4F54  # "MOT": slip
IMU_STREAM = 0x494D55  # "IMU"
COMPASS_STREAM = 0x434D50  # "CMP"


class SimRobot:
    """The scenario's true robot around the nominal `robot`, at (x, y, theta), wheels at rest."""

    def __init__(
        self,
        robot: RobotConfig,
        scenario: Scenario,
        seed: int,
        x: float = 0.0,  # [m] map frame
        y: float = 0.0,  # [m]
        theta: float = 0.0,  # [rad]
        encoder_start: int = 0,  # [ticks] count both encoders read at the start
        body_radius: float = 0.0,  # [m] the footprint other robots' bodies keep out of (0: none)
        walls: Walls | None = None,  # the field's walls its footprint keeps inside (none without a footprint)
        chassis: Chassis | None = None,  # its footprint against the walls (None: the disc)
        obstacles: Sequence[Shape] = (),  # the field's obstacles its footprint keeps out of (none without a footprint)
    ) -> None:
        self.robot = robot
        self.body_radius = body_radius
        self.walls = walls if body_radius > 0.0 else None
        self.chassis = chassis if self.walls is not None else None  # it meets the walls only
        self.obstacles = tuple(obstacles) if body_radius > 0.0 else ()
        self.met: list[str] = []  # the other bodies the last step met
        self.scenario = scenario
        self.body = body.world(robot, scenario)
        self.encoder_start = encoder_start
        self.state = body.teleport(body.State(), x, y, theta)
        self.reseed(seed)

    def reseed(self, seed: int) -> None:
        """Start every random stream again from `seed`."""
        self._motion = np.random.default_rng([seed, MOTION_STREAM])
        self._imu = np.random.default_rng([seed, IMU_STREAM])
        self._compass = np.random.default_rng([seed, COMPASS_STREAM])

    def wheels(self, v: float, omega: float) -> tuple[float, float]:
        """Wheel commands [rad/s] for v [m/s], omega [rad/s] through the nominal geometry,
        both scaled by one factor to the robot's max wheel speed (the curvature kept)."""
        half, r = self.robot.track_width / 2.0, self.robot.wheel_radius
        left, right = (v - omega * half) / r, (v + omega * half) / r
        k = min(1.0, self.robot.max_wheel_speed / max(abs(left), abs(right), 1e-12))
        return left * k, right * k

    def step(self, cmd_left: float, cmd_right: float, dt: float, others: Mapping[str, Disc] | None = None) -> body.State:
        """Move on by dt [s] under wheel commands [rad/s], kept out of `others` and inside the walls (bodies.block,
        or the chassis's bodies.chassis_travel); the new state. The wheels turn all the same (the encoders count
        it): a step held back moves the ground less, and the accelerometer feels the body's change of speed."""
        s0 = self.state
        s = body.step(s0, self.body, cmd_left, cmd_right, dt, self._motion)
        self.met = []
        walls, chassis = self.walls, self.chassis
        if chassis is not None and walls is not None:  # the chassis meets the walls, the disc below the other robots
            track = self.body.track
            ds, dtheta = s.v * dt, s.omega * dt
            left, right, self.met = chassis_travel(
                s0.x, s0.y, s0.theta, ds - dtheta * track / 2, ds + dtheta * track / 2, track, chassis, walls
            )
            if self.met:
                ds, dtheta = (left + right) / 2.0, (right - left) / track
                x, y, theta = body.arc(s0.x, s0.y, s0.theta, ds, dtheta)
                s = s._replace(x=x, y=y, theta=theta, v=ds / dt, omega=dtheta / dt)
        disc_walls = walls if chassis is None else None
        if self.body_radius > 0.0 and (others or disc_walls is not None or self.obstacles):
            x, y, met = block(s0.x, s0.y, s.x, s.y, self.body_radius, others or {}, disc_walls, self.obstacles)
            if met:
                mid = s0.theta + wrap_angle(s.theta - s0.theta) / 2.0
                s = s._replace(x=x, y=y, v=((x - s0.x) * math.cos(mid) + (y - s0.y) * math.sin(mid)) / dt)
                self.met += met
        if chassis is not None and walls is not None:  # the arc's curve, or another robot's slide
            x, y = chassis_inside(s0.x, s0.y, s0.theta, s.x, s.y, s.theta, chassis, walls)
            if (x, y) != (s.x, s.y):
                s = s._replace(x=x, y=y)
        if self.met:  # held: the body, not the motors, is what the accelerometer feels (the stop, then nothing)
            s = s._replace(accel=(s.v - s0.v) / dt)
        self.state = s
        return s

    def drive(self, v: float, omega: float, dt: float) -> body.State:
        """Move on by dt [s] under a body velocity command (v [m/s], omega [rad/s]); the new state."""
        return self.step(*self.wheels(v, omega), dt)

    def teleport(self, x: float | None = None, y: float | None = None, theta: float | None = None) -> body.State:
        """Put the robot down at a new pose (unset: keep), wheels stopped, encoders kept."""
        self.state = body.teleport(self.state, x, y, theta)
        return self.state

    def encoders(self) -> tuple[int, int]:
        """(left, right) counts [ticks], quantised and wrapped to int32 as the hardware does."""
        tpr, s = self.scenario.ticks_per_rev, self.state
        return sensors.encoder_ticks(s.angle_left, tpr, self.encoder_start), sensors.encoder_ticks(s.angle_right, tpr, self.encoder_start)

    def imu(self) -> tuple[float, float, float]:
        """(gyro_z [rad/s], accel_x, accel_y [m/s^2]) in the body frame, with the scenario's errors."""
        return sensors.imu(self.state, self.scenario, self._imu)

    def compass(self) -> float:
        """Heading [rad, map frame] with noise and the disturbance."""
        return sensors.compass(self.state, self.scenario, self._compass)
