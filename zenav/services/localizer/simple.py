"""The baseline modes: dead reckoning, and fixes that overwrite or are weighted in by speed.

- dead_reckoning: odometry increments only, from the pose set_pose gave.
- overwrite: a fix replaces x, y (the heading stays dead-reckoned).
- speed_weighted: x, y move towards the fix by a confidence that falls with speed,
  1 - |v| / top speed (the odometry's speed).
- speed_weighted_latency: the same, after carrying the fix forward by the dead-reckoned
  motion since its capture time (a path history).

Their covariance is a rule of thumb: the fix's sigma plus a growth per metre driven.
"""

from __future__ import annotations

import bisect
import math
from collections import deque

from zenav.common import messages as m
from zenav.common.config import RobotConfig
from zenav.common.geometry import Pose2, wrap_angle

from .base import FixResult, LocalizerConfig, Mode
from .gyro import GyroIntegral


class DeadReckoning(Mode):
    """Odometry only, placed in the map by set_pose."""

    def __init__(self, cfg: LocalizerConfig, robot: RobotConfig) -> None:
        super().__init__(cfg, robot)
        self.est = Pose2()
        self.sigma = [cfg.unknown_sigma_xy, math.pi]  # [m, rad] at the last reset of position, heading
        self.driven = [0.0, 0.0]  # [m] driven since each reset

    def _start(self, pose: Pose2) -> None:
        self.est = pose

    def _move(self, ds: float, dth: float, t0: float, t: float) -> None:
        mid = self.est.theta + dth / 2.0
        self.est = Pose2(self.est.x + ds * math.cos(mid), self.est.y + ds * math.sin(mid), wrap_angle(self.est.theta + dth))
        step = abs(ds) + abs(dth) * self.robot.track_width / 2.0
        self.driven = [d + step for d in self.driven]

    def _sigmas(self) -> tuple[float, float]:
        """[m, rad] the rule of thumb: sigma at the reset plus a growth per metre driven."""
        xy, th = (s + self.cfg.drift_per_m * d for s, d in zip(self.sigma, self.driven))
        return min(xy, self.cfg.unknown_sigma_xy), min(th, math.pi)

    def _reset(self, i: int, sigma: float) -> None:
        self.sigma[i], self.driven[i] = sigma, 0.0

    def _set(self, x: float | None, y: float | None, theta: float | None) -> None:
        e = self.est
        self.est = Pose2(e.x if x is None else x, e.y if y is None else y, e.theta if theta is None else theta)
        if x is not None and y is not None:
            self._reset(0, self.cfg.set_pose_sigma_xy)
        if theta is not None:
            self._reset(1, self.cfg.set_pose_sigma_theta)

    def _fix(self, fix: m.VpsPose, t: float, t_arrival: float) -> FixResult:
        return FixResult(False, "ignored")

    def _estimate(self) -> tuple[Pose2, tuple[float, ...]]:
        xy, th = self._sigmas()
        return self.est, (xy * xy, 0.0, 0.0, 0.0, xy * xy, 0.0, 0.0, 0.0, th * th)

    def _blend(self, fix: m.VpsPose, x: float, y: float, weight: float) -> FixResult:
        """Move x, y towards the fix position (x, y) by `weight` in [0, 1]."""
        e = self.est
        innovation = (x - e.x, y - e.y, wrap_angle(fix.theta - e.theta))
        self.est = Pose2(e.x + weight * innovation[0], e.y + weight * innovation[1], e.theta)
        self._reset(0, weight * self.cfg.fix_sigma_xy + (1.0 - weight) * self._sigmas()[0])
        return FixResult(True, "accepted", innovation)


class Overwrite(DeadReckoning):
    """x, y = the fix."""

    def _fix(self, fix: m.VpsPose, t: float, t_arrival: float) -> FixResult:
        return self._blend(fix, fix.x, fix.y, 1.0)


class SpeedWeighted(DeadReckoning):
    """Confidence-weighted average, trusting the fix more when slow."""

    def confidence(self) -> float:
        """Weight of a fix: 1 standing still, 0 at the robot's top speed."""
        top = self.robot.max_wheel_speed * self.robot.wheel_radius  # [m/s]
        return max(0.0, 1.0 - abs(self.last.v) / top)

    def _fix(self, fix: m.VpsPose, t: float, t_arrival: float) -> FixResult:
        return self._blend(fix, fix.x, fix.y, self.confidence())


class SpeedWeightedLatency(SpeedWeighted):
    """The speed-weighted average, with the fix carried forward along the path history."""

    def __init__(self, cfg: LocalizerConfig, robot: RobotConfig) -> None:
        super().__init__(cfg, robot)
        self.path: deque[tuple[float, float, float]] = deque()  # (t, total dx, total dy) dead-reckoned [s, m, m]

    def _start(self, pose: Pose2) -> None:
        super()._start(pose)
        self.path.append((self.last.t, 0.0, 0.0))

    def _move(self, ds: float, dth: float, t0: float, t: float) -> None:
        before = self.est
        super()._move(ds, dth, t0, t)
        _, sx, sy = self.path[-1]
        self.path.append((t, sx + self.est.x - before.x, sy + self.est.y - before.y))
        while len(self.path) > 2 and self.path[1][0] <= t - self.cfg.history:
            self.path.popleft()

    def _set(self, x: float | None, y: float | None, theta: float | None) -> None:
        super()._set(x, y, theta)
        self.path = deque([(self.last.t, 0.0, 0.0)])

    def _fix(self, fix: m.VpsPose, t: float, t_arrival: float) -> FixResult:
        if t < self.path[0][0]:
            return FixResult(False, "too_old")
        i = bisect.bisect_left(self.path, t, key=lambda p: p[0])
        t1, x1, y1 = self.path[i]
        t0, x0, y0 = self.path[i - 1] if i > 0 else self.path[i]
        f = (t - t0) / (t1 - t0) if t1 > t0 else 1.0
        _, xn, yn = self.path[-1]
        dx, dy = xn - (x0 + f * (x1 - x0)), yn - (y0 + f * (y1 - y0))
        return self._blend(fix, fix.x + dx, fix.y + dy, self.confidence())


class Complementary(DeadReckoning):
    """A complementary filter: fixed-weight averages of the sensors' heading changes, pulled to the compass and the fixes."""

    sensors = ("sensors/imu", "sensors/compass")

    def __init__(self, cfg: LocalizerConfig, robot: RobotConfig) -> None:
        super().__init__(cfg, robot)
        self.gyro = GyroIntegral(cfg.history, cfg.gyro_max_gap)

    def on_imu(self, imu: m.Imu) -> str | None:
        return None if self.gyro.add(imu.t, imu.gyro_z) else "stale"

    def on_compass(self, compass: m.Compass) -> None:
        if self.odom is not None:
            e, w = self.est, self.cfg.complementary_compass_weight
            self.est = Pose2(e.x, e.y, wrap_angle(e.theta + w * wrap_angle(compass.heading - e.theta)))

    def _move(self, ds: float, dth: float, t0: float, t: float) -> None:
        g = self.gyro.between(t0, t)
        if g is not None:
            w = self.cfg.complementary_gyro_weight
            dth = w * g + (1.0 - w) * dth
        super()._move(ds, dth, t0, t)

    def _fix(self, fix: m.VpsPose, t: float, t_arrival: float) -> FixResult:
        return self._blend(fix, fix.x, fix.y, self.cfg.complementary_fix_weight)
