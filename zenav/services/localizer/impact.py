"""The accelerometer against the odometry: an impact, or wheels that turn while the robot does not.

The accelerometer's forward reading, integrated, is the body's change of speed; the
odometry's is the wheels'. While the wheels grip, the two agree. A robot that meets a
wall or another robot, is held by one, or is pushed, changes speed without its wheels
(or its wheels without it), and the two part. Their difference is integrated with a
leak (`leak`, which takes out the accelerometer's bias and the odometry's tick steps);
past `speed` the wheels are slipping.

The odometry's speed is its mean over a window, which is the speed at the window's
middle: the accelerometer's change is taken between those middles, so that a hard start
(both change together) is no disagreement. The window is WINDOW, or longer where the
encoders are coarse: long enough that one tick is a small part of `speed` (TICKS). Over
more than MAX_WINDOW the mean is no longer the middle's speed (a robot that starts and
stops): encoders that coarse cannot tell an impact, and the accelerometer is not read.
An IMU that carries no accelerometer (both readings exactly 0) is not used. An IMU off
the middle of the wheels' axle feels a turn too (its centripetal and tangential
acceleration, from the gyro's rate): that is taken out first. Pure: samples in, a
verdict out.
"""

from __future__ import annotations

import math
from collections import deque

from .gyro import GyroIntegral

WINDOW = 0.04  # [s] of odometry averaged into one speed, at least
TICKS = 4.0  # [-] the window is at least this many ticks' travel at `speed`: a tick moves the mean speed by a quarter of it
MAX_WINDOW = 0.1  # [s] the longest window: at 0.05 m/s, a tick of 1.25 mm (360 ticks a turn of a wheel 14 cm across)


def window(speed: float, tick: float) -> float | None:
    """[s] the odometry averaged to tell a speed change of `speed` [m/s] with ticks of `tick` [m]; None: too coarse."""
    w = max(WINDOW, TICKS * tick / speed)
    return w if w <= MAX_WINDOW else None


class Impact:
    """Says, per odom sample, whether the body's and the wheels' speeds have parted by more than `speed`."""

    def __init__(self, speed: float, leak: float, window: float, keep: float, max_gap: float, at: tuple[float, float] = (0.0, 0.0)):
        self.speed = speed  # [m/s] the disagreement that is an impact
        self.at = at  # [m] the IMU ahead of the middle of the wheels' axle, and left of it
        self.turn: tuple[float, float] | None = None  # (t [s], yaw rate [rad/s]) of the previous IMU sample
        self.leak = leak  # [s] the leak's time constant
        self.window = window  # [s] of odometry averaged into one speed (`window`)
        self.accel = GyroIntegral(keep, max_gap)  # the accelerometer's forward reading, integrated: speed change
        self.odom: deque[tuple[float, float, float]] = deque()  # (t0, t, forward travel) of the increments over the window
        self.travel = 0.0  # [m] their sum
        self.mid: tuple[float, float] | None = None  # (middle time, mean speed) of the previous window
        self.gap = 0.0  # [m/s] the wheels' speed change minus the body's, leaky

    def on_imu(self, t: float, accel_x: float, accel_y: float, gyro_z: float) -> None:
        """An IMU sample at t [s]: the accelerometer [m/s^2] (the mean over the span since the previous one), the gyro's
        yaw rate [rad/s]."""
        if accel_x == 0.0 and accel_y == 0.0:
            return  # no accelerometer: the gyro alone
        prev, self.turn = self.turn, (t, gyro_z)
        spin = 0.0 if prev is None or t <= prev[0] else (gyro_z - prev[1]) / (t - prev[0])  # [rad/s^2]
        # At (x, y) off the axle's middle a turn adds -rate^2 x - spin y to the forward reading: the axle's is the rest.
        x, y = self.at
        self.accel.add(t, accel_x + gyro_z * gyro_z * x + spin * y)

    def on_odom(self, t0: float, t: float, ds: float) -> bool:
        """An odometry increment of ds [m] forward from t0 to t [s]; True while the speeds disagree."""
        self.odom.append((t0, t, ds))
        self.travel += ds
        while self.odom[0][1] <= t - self.window + 1e-6:  # (a float's rounding does not keep one more)
            self.travel -= self.odom.popleft()[2]
        start = self.odom[0][0]
        mid = (start + t) / 2.0, self.travel / (t - start)
        prev, self.mid = self.mid, mid
        if prev is None or mid[0] <= prev[0]:
            return abs(self.gap) > self.speed
        body = self.accel.between(prev[0], mid[0])
        if body is None:  # no accelerometer over the span: nothing to compare
            self.gap = 0.0
            return False
        keep = math.exp(-(mid[0] - prev[0]) / self.leak)
        self.gap = (self.gap + (mid[1] - prev[1]) - body) * keep
        return abs(self.gap) > self.speed
