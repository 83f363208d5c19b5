"""The estimate_average mode: weighted averages of every sensor's estimate of a step, with the camera's fixes weighted in.

Each odom increment gives the encoders' distance and angle change (the odometry's
heading: from the encoders when [odometry] heading_source = "encoders"); the IMU gives
the gyro's angle change and the accelerometer's distance and angle change
(averaging.py). x and y move by the weighted average of the six
(distance, angle) estimates, the heading by the weighted average of the angle changes.
A fix moves x, y and the heading a fixed fraction of the way towards it, as the method
weights the camera in: it is not carried forward over its latency.
"""

from __future__ import annotations

from zenav.common import messages as m
from zenav.common.config import RobotConfig
from zenav.common.geometry import Pose2, wrap_angle
from zenav.services.localizer import averaging

from .base import FixResult, LocalizerConfig
from .simple import DeadReckoning

STILL_TIME = 0.5  # [s] no odom motion for this long: standing still (speed zero, biases learned)
HALT_TIME = 0.1  # [s] no forward odom travel for this long: the forward speed is zero
BIAS_TIME = 5.0  # [s] time constant of the bias averages
IMU_GAP = 0.1  # [s] the IMU silent for longer than this is missing for a step


class EstimateAverage(DeadReckoning):
    """Encoder and accelerometer distances with encoder, gyro and accelerometer angles: the 12 estimates (x and y of six) averaged."""

    sensors = ("sensors/imu",)

    def __init__(self, cfg: LocalizerConfig, robot: RobotConfig) -> None:
        super().__init__(cfg, robot)
        self.inertial = averaging.Inertial()
        self.t_moved = 0.0  # [s] newest odom increment with motion
        self.t_forward = 0.0  # [s] newest odom increment with forward travel

    def on_imu(self, imu: m.Imu) -> str | None:
        s = self.inertial
        if s.t is not None and imu.t <= s.t:
            return "stale"
        known = self.odom is not None
        halted = known and imu.t - self.t_forward >= HALT_TIME
        still = known and imu.t - self.t_moved >= STILL_TIME
        self.inertial = averaging.imu_sample(s, imu.t, imu.gyro_z, imu.accel_x, imu.accel_y, halted, still, BIAS_TIME)
        return None

    def _move(self, ds: float, dth: float, t0: float, t: float) -> None:
        if ds != 0.0:
            self.t_forward = t
        if ds != 0.0 or dth != 0.0:
            self.t_moved = t
        self.inertial, gyro, travel, accel_angle = averaging.take(self.inertial)
        fresh = self.inertial.t is not None and t - self.inertial.t <= IMU_GAP
        e = self.est
        dx, dy, dtheta = averaging.combine(
            e.theta,
            (ds, travel if fresh else None),
            (dth, gyro if fresh else None, accel_angle if fresh else None),
            self.cfg.estimate_average_distance_weights,
            self.cfg.estimate_average_angle_weights,
        )
        self.est = Pose2(e.x + dx, e.y + dy, wrap_angle(e.theta + dtheta))
        step = abs(ds) + abs(dth) * self.robot.track_width / 2.0
        self.driven = [d + step for d in self.driven]

    def _fix(self, fix: m.VpsPose, t: float, t_arrival: float) -> FixResult:
        res = self._blend(fix, fix.x, fix.y, self.cfg.estimate_average_fix_weight)
        w = self.cfg.estimate_average_fix_heading_weight
        e = self.est  # the camera's heading is weighted in too: nothing else bounds the gyro's drift
        self.est = Pose2(e.x, e.y, wrap_angle(e.theta + w * res.innovation[2]))
        self._reset(1, w * self.cfg.fix_sigma_theta + (1.0 - w) * self._sigmas()[1])
        return res
