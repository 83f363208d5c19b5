"""Point trackers, each `(pose, target, params) -> (v, omega)`, and the wheel limits.

- `RotationPid`: a PID on the bearing to the goal, with a forward speed
  proportional to the distance that falls to zero while the bearing error is large.
- `polar` (Siegwart's rho/alpha/beta): v = k_rho rho, omega = k_alpha alpha +
  k_beta beta, driving backwards when the goal starts behind.
- `proportional`: forward speed proportional to the distance, weighted by
  the cosine of the bearing error, and a proportional turn toward the goal.
- `carrot` (LemLib's boomerang): move_to_pose drives a point tracker to a point behind
  the goal pose that slides onto it as the robot closes in.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import NamedTuple

from zenav.common.geometry import wrap_angle
from zenav.services.navigator.params import Params


class PoseSample(NamedTuple):
    """The robot's estimated state at time t (map frame)."""

    t: float  # [s]
    x: float  # [m]
    y: float  # [m]
    theta: float  # [rad]
    v: float = 0.0  # [m/s] measured forward speed
    omega: float = 0.0  # [rad/s] measured turn rate
    sigma_xy: float = 0.0  # [m] 1 sigma of the position along its most uncertain axis
    sigma_theta: float = 0.0  # [rad] 1 sigma of the heading
    slipping: bool = False  # the localizer finds the wheels slipping: x, y wait for the fixes
    pose_t: float | None = None  # [s] steered on odometry: t of the localizer's pose whose correction it carries (None: t)

    @property
    def since(self) -> float:
        """[s] the t its age counts from: its localizer pose's (a stale pose is stale however fresh the odometry)."""
        return self.t if self.pose_t is None else self.pose_t


def sigmas(cov: Sequence[float]) -> tuple[float, float]:
    """(position sigma along the worst axis [m], heading sigma [rad]) of a row-major 3x3 (x, y, theta) covariance."""
    a, b, d = cov[0], (cov[1] + cov[3]) / 2.0, cov[4]
    worst = (a + d) / 2.0 + math.sqrt(((a - d) / 2.0) ** 2 + b * b)  # the larger eigenvalue of the xy block
    return math.sqrt(max(worst, 0.0)), math.sqrt(max(cov[8], 0.0))


class Target(NamedTuple):
    """A point to reach, the heading to arrive with, and the speed limit."""

    x: float  # [m]
    y: float  # [m]
    theta: float  # [rad] approach heading (the direction of travel, reversed when backing)
    speed: float  # [m/s] forward speed limit of the goal
    reverse: bool = False  # drive backwards to it (polar, goal behind at the start)
    lead: float = 0.0  # [-] boomerang: carrot distance behind the point per metre to it


class Wheelbase(NamedTuple):
    """The nominal geometry the wheel speed limit is computed with."""

    track: float  # [m]
    radius: float  # [m]
    max_wheel_speed: float  # [rad/s]


Controller = Callable[[PoseSample, Target, Params], tuple[float, float]]


def make_target(pose: PoseSample, x: float, y: float, speed: float, allow_reverse: bool) -> Target:
    """The target (x, y) approached from `pose`; backwards if allowed and it lies behind."""
    bearing = math.atan2(y - pose.y, x - pose.x)
    reverse = allow_reverse and abs(wrap_angle(bearing - pose.theta)) > math.pi / 2
    return Target(x, y, wrap_angle(bearing + math.pi) if reverse else bearing, speed, reverse)


def check_polar_gains(k_rho: float, k_alpha: float, k_beta: float) -> None:
    """Raise ValueError, naming the equation, unless the gains meet the polar tracker's stability conditions, eq. 8 and eq. 9.

    Eq. 8: the linearised system (eq. 6) is stable: k_rho > 0, k_beta < 0, k_alpha - k_rho > 0
    (the roots of eq. 7). Eq. 9, the strong stability condition (Siegwart): also
    k_alpha + 5/3 k_beta - 2/pi k_rho > 0.
    """
    gains = f"polar gains k_rho={k_rho:g}, k_alpha={k_alpha:g}, k_beta={k_beta:g}"
    if k_rho <= 0 or k_beta >= 0 or k_alpha - k_rho <= 0:
        raise ValueError(
            f"unstable {gains}: the linearised system (eq. 8) needs k_rho > 0, k_beta < 0 and "
            f"k_alpha - k_rho > 0 (it is {k_alpha - k_rho:.3g})"
        )
    margin = k_alpha + 5.0 / 3.0 * k_beta - 2.0 / math.pi * k_rho
    if margin <= 0:
        raise ValueError(
            f"unstable {gains}: the strong stability condition (eq. 9) needs k_alpha + 5/3 k_beta - 2/pi k_rho > 0 (it is {margin:.3g})"
        )


def carrot(pose: PoseSample, x: float, y: float, theta: float, lead: float) -> tuple[float, float]:
    """Boomerang (LemLib's moveToPose): the point `lead` x distance behind the goal pose, along its heading [m]."""
    d = math.hypot(x - pose.x, y - pose.y)
    return x - lead * d * math.cos(theta), y - lead * d * math.sin(theta)


def _bearing_error(pose: PoseSample, target: Target) -> tuple[float, float]:
    """Distance [m] and bearing error [rad] from the pose to the target point."""
    dx, dy = target.x - pose.x, target.y - pose.y
    return math.hypot(dx, dy), wrap_angle(math.atan2(dy, dx) - pose.theta)


def _clamp(value: float, low: float, high: float) -> float:
    return max(low, min(high, value))


class RotationPid:
    """Rotation PID toward the goal, proportional forward speed."""

    def __init__(self) -> None:
        self.integral = 0.0  # [rad * s]
        self.t: float | None = None  # [s] time of the previous call

    def __call__(self, pose: PoseSample, target: Target, params: Params) -> tuple[float, float]:
        dist, err = _bearing_error(pose, target)
        dt = 0.0 if self.t is None else max(pose.t - self.t, 0.0)
        self.t = pose.t
        self.integral = _clamp(self.integral + err * dt, -params.pid_i_limit, params.pid_i_limit)
        omega = params.pid_kp * err + params.pid_ki * self.integral - params.pid_kd * pose.omega
        v = _clamp(params.pid_speed_gain * dist, params.crawl_speed, target.speed)
        return v * max(0.0, 1.0 - abs(err) / params.pid_heading_limit), omega


def polar(pose: PoseSample, target: Target, params: Params) -> tuple[float, float]:
    """Rho/alpha/beta tracking, speed scaled down to the limit, keeping the curvature."""
    rho, alpha = _bearing_error(pose, target)
    beta = wrap_angle(target.theta - pose.theta - alpha)
    if target.reverse:  # the back of the robot is its front
        alpha, beta = wrap_angle(alpha + math.pi), wrap_angle(beta + math.pi)
    v = params.k_rho * rho
    omega = params.k_alpha * alpha + params.k_beta * beta
    if v > target.speed:
        omega *= target.speed / v
        v = target.speed
    v = max(v, params.crawl_speed)
    return (-v, omega) if target.reverse else (v, omega)


def proportional(pose: PoseSample, target: Target, params: Params) -> tuple[float, float]:
    """Speed proportional to the distance, turn proportional to the bearing error."""
    dist, err = _bearing_error(pose, target)
    v = _clamp(params.prop_speed_gain * dist, params.crawl_speed, target.speed)
    return v * max(0.0, math.cos(err)), params.prop_heading_gain * err


def boomerang(pose: PoseSample, target: Target, params: Params) -> tuple[float, float]:
    """LemLib's moveToPose: turn toward the carrot, speed from the distance to the goal point."""
    cx, cy = carrot(pose, target.x, target.y, target.theta, target.lead)
    dist = math.hypot(target.x - pose.x, target.y - pose.y)
    err = wrap_angle(math.atan2(cy - pose.y, cx - pose.x) - pose.theta)
    v = _clamp(params.prop_speed_gain * dist, params.crawl_speed, target.speed)
    return v * max(0.0, math.cos(err)), params.prop_heading_gain * err


def make(name: str) -> Controller:
    """A fresh controller by config name (pid keeps state: one per target)."""
    if name == "pid":
        return RotationPid()
    return {"polar": polar, "proportional": proportional, "boomerang": boomerang}[name]


def limit(v: float, omega: float, max_turn_speed: float, wheels: Wheelbase) -> tuple[float, float]:
    """Scale (v, omega) down together, keeping the curvature, to the turn and wheel limits."""
    scale = 1.0
    if abs(omega) > max_turn_speed:
        scale = max_turn_speed / abs(omega)
    wheel = (abs(v) + abs(omega) * wheels.track / 2.0) / wheels.radius  # [rad/s] the faster wheel
    if wheel * scale > wheels.max_wheel_speed:
        scale = wheels.max_wheel_speed / wheel
    return v * scale, omega * scale
