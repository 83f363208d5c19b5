"""The simulated robot stepped in time: its true body and its sensors, one seeded generator each.

    bot = SimRobot(Robot(), scenario, seed=1)
    bot.drive(0.2, 0.0, 0.01)          # body velocity through the nominal wheel geometry
    bot.step(5.0, 5.0, 0.01)           # or wheel commands [rad/s]
    bot.state.x, bot.encoders(), bot.imu(), bot.compass()

Pure: time comes in as dt. The body's slip and each sensor's noise draw from their own
generator, so reading a sensor (or not) never changes the path the robot takes.
"""

from __future__ import annotations

import numpy as np

from zenav.common.config import Robot
from zenav.common.scenarios import Scenario
from zenav.world import robot as body
from zenav.world import sensors

# Seed streams, mixed with the seed (numpy SeedSequence entropy words).
MOTION_STREAM = 0x4D4F54  # "MOT": slip
IMU_STREAM = 0x494D55  # "IMU"
COMPASS_STREAM = 0x434D50  # "CMP"


class SimRobot:
    """The scenario's true robot around the nominal `robot`, at (x, y, theta), wheels at rest."""

    def __init__(
        self,
        robot: Robot,
        scenario: Scenario,
        seed: int,
        x: float = 0.0,  # [m] map frame
        y: float = 0.0,  # [m]
        theta: float = 0.0,  # [rad]
        encoder_start: int = 0,  # [ticks] count both encoders read at the start
    ) -> None:
        self.robot = robot
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

    def step(self, cmd_left: float, cmd_right: float, dt: float) -> body.State:
        """Move on by dt [s] under wheel commands [rad/s]; the new state."""
        self.state = body.step(self.state, self.body, cmd_left, cmd_right, dt, self._motion)
        return self.state

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
