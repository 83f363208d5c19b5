"""The localizer's config and the interface every mode implements (get_pose / set_pose, fed by odometry and fixes).

A mode is fed odometry samples (`on_odom`) and VPS fixes (`on_fix`, with their
arrival time), answers `get_pose` for the newest odom sample, and can be reset with
`set_pose` (any subset of x, y, theta: a position, a heading, or both).
The checks every mode shares (stale odometry, jumps, fixes from before a reset or
from the future) live here.
"""

from __future__ import annotations

import math
import statistics
from collections import deque
from dataclasses import dataclass
from typing import Annotated, Literal, get_args

import msgspec
import numpy as np
from msgspec import Meta, Struct

from zenav.common import messages as m
from zenav.common.config import RobotConfig
from zenav.common.geometry import Pose2, wrap_angle

from .latency import Estimate, LatencyEstimator, LatencyParams

Pos = Annotated[float, Meta(gt=0.0, le=1e3)]
NonNegW = Annotated[float, Meta(ge=0.0, le=1e3)]  # a weight [-]
DUPLICATE_WINDOW = 64  # fixes: one equal to any of this many recent ones is a duplicate
MIN_FIX_VAR = 1e-6  # [m^2] and [rad^2] floor of a fix's variances (1 mm, 1 mrad)
ModeName = Literal[
    "ekf", "ekf_no_delay", "dead_reckoning", "overwrite", "speed_weighted", "speed_weighted_latency", "complementary", "estimate_average"
]
MODES: tuple[str, ...] = get_args(ModeName)


class LocalizerConfig(Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """The [localizer] section."""

    mode: ModeName = "ekf"  # fusion rule (see services/localizer/README.md): ekf is the best measured
    history: Annotated[float, Meta(ge=0.1, le=60.0)] = 1.5  # [s] odometry kept to apply late fixes at capture time
    # ekf: odom samples one step of that history spans at most; a late fix re-integrates the history since its capture
    # step by step (1: every sample a step of its own)
    history_samples: Annotated[int, Meta(ge=1, le=100)] = 2
    future_tolerance: Annotated[float, Meta(ge=0.0, le=1.0)] = 0.05  # [s] a fix this far past the newest odom applies to it
    max_odom_step: Pos = 0.2  # [m] a larger odom increment is a jump (odometry restart), not motion
    gate: Pos = 16.3  # squared Mahalanobis distance above which a fix is an outlier (chi2, 3 dof, 99.9 %)
    recover_after: Annotated[int, Meta(ge=1, le=1000)] = 5  # consecutive rejected fixes before re-acquiring
    wheel_noise: Pos = 1e-6  # [m^2/m] variance of each wheel's travel (slip) per metre it travels
    # [m^2/m] ekf: variance of the position per metre the odometry travels while its wheels are found slipping (pushing
    # against another robot or a wall: the accelerometer or the fixes disagree with the odometry); 0: never found slipping
    slip_noise: Annotated[float, Meta(ge=0.0, le=100.0)] = 0.05
    slip_hold: Annotated[float, Meta(gt=0.0, le=60.0)] = 1.0  # [s] ekf: how long slip lasts after the last sample or fix finding it
    # [m/s] ekf: the accelerometer's and the odometry's forward speed changes parting by more than this find the wheels
    # slipping at once (an impact, a hold, a push: impact.py); 0: the accelerometer is not read
    impact_speed: Annotated[float, Meta(ge=0.0, le=10.0)] = 0.05
    impact_leak: Annotated[float, Meta(gt=0.0, le=10.0)] = 0.25  # [s] ekf: time constant their difference fades with
    calib_noise: Annotated[float, Meta(ge=0.0, le=1.0)] = 1e-8  # [1/m] random walk variance of each calibration error per metre
    calib_sigma: Annotated[float, Meta(ge=0.0, le=0.5)] = 0.05  # 1-sigma prior of each relative calibration error
    gyro_noise: Pos = 6e-4  # [rad/sqrt(s)] angle random walk of the integrated gyro (when sensors/imu is there)
    gyro_bias_noise: Annotated[float, Meta(ge=0.0, le=1.0)] = 1e-5  # [rad/s/sqrt(s)] random walk of the gyro bias
    gyro_bias_sigma: Pos = 0.05  # [rad/s] 1-sigma prior of the gyro bias
    gyro_max_gap: Pos = 0.1  # [s] a longer silence of the gyro restarts its integral
    complementary_gyro_weight: Annotated[float, Meta(ge=0.0, le=1.0)] = 0.8  # complementary: weight of the gyro's heading change
    complementary_compass_weight: Annotated[float, Meta(ge=0.0, le=1.0)] = 0.02  # complementary: pull towards each compass heading
    complementary_fix_weight: Annotated[float, Meta(ge=0.0, le=1.0)] = 0.3  # complementary: pull towards each fix position
    fix_sigma_xy: Pos = 0.02  # [m] 1-sigma of a fix that carries no covariance
    fix_sigma_theta: Pos = 0.035  # [rad] 1-sigma of a fix heading that carries no covariance
    unknown_sigma_xy: Pos = 10.0  # [m] 1-sigma of the position before the first fix or set_pose
    set_pose_sigma_xy: Pos = 0.005  # [m] 1-sigma of a position given by set_pose
    set_pose_sigma_theta: Pos = 0.01  # [rad] 1-sigma of a heading given by set_pose
    drift_per_m: Pos = 0.05  # [m/m] and [rad/m] growth of the reported sigma of the simple modes per metre driven
    stale_fix: Pos = 3.0  # [s] without an accepted fix, diag is degraded
    expected_latency: Annotated[float, Meta(ge=0.0, le=60.0)] = 0.3  # [s] VPS latency the deployment expects (only compared)
    latency_tolerance: Pos = 0.1  # [s] a measured latency further off than this is reported
    latency_window: Annotated[int, Meta(ge=1, le=10_000)] = 50  # fixes over which the latency median is taken
    latency: Literal["stamped", "estimate"] = "stamped"  # a fix's capture time: its stamp, or arrival - estimated latency
    latency_max: Annotated[float, Meta(gt=0.0, le=10.0)] = 1.0  # [s] estimate: largest latency searched
    latency_step: Annotated[float, Meta(gt=0.0, le=1.0)] = 0.01  # [s] estimate: grid of the search
    latency_fit_window: Annotated[float, Meta(gt=0.0, le=60.0)] = 4.0  # [s] estimate: fixes fitted together
    estimate_average_distance_weights: tuple[NonNegW, NonNegW] = (1.0, 0.0)  # estimate_average: encoders, accelerometer distance [-]
    estimate_average_angle_weights: tuple[NonNegW, NonNegW, NonNegW] = (1.0, 3.0, 0.0)  # estimate_average: encoders, gyro, accel angle [-]
    estimate_average_fix_weight: Annotated[float, Meta(ge=0.0, le=1.0)] = 0.1  # estimate_average: fraction of the way x, y move to a fix
    estimate_average_fix_heading_weight: Annotated[float, Meta(ge=0.0, le=1.0)] = 0.05  # estimate_average: ... and the heading


def latency_estimator(cfg: LocalizerConfig) -> LatencyEstimator:
    """The online latency estimator of [localizer] latency = "estimate", its prior the expected latency."""
    p = LatencyParams(
        prior=cfg.expected_latency,
        prior_sigma=cfg.latency_tolerance,
        max_lag=cfg.latency_max,
        step=cfg.latency_step,
        window=cfg.latency_fit_window,
        sigma_xy=cfg.fix_sigma_xy,
        sigma_theta=cfg.fix_sigma_theta,
        max_odom_step=cfg.max_odom_step,
    )
    return LatencyEstimator(p)


@dataclass(frozen=True)
class FixResult:
    """What a mode did with one fix."""

    accepted: bool
    reason: str
    innovation: tuple[float, float, float] = (0.0, 0.0, 0.0)  # fix minus prediction at capture
    mahalanobis_d2: float = 0.0  # 0 where the mode does not gate
    replay_depth: int = 0  # odom samples re-integrated


def fix_cov(fix: m.VpsPose, cfg: LocalizerConfig) -> np.ndarray:
    """The fix's 3x3 covariance made usable (symmetric, positive), or the configured one when it carries none."""
    if not any(fix.cov):
        return np.diag([cfg.fix_sigma_xy**2] * 2 + [cfg.fix_sigma_theta**2])
    R = np.array(fix.cov).reshape(3, 3)
    R = (R + R.T) / 2.0
    np.fill_diagonal(R, np.maximum(np.diag(R), MIN_FIX_VAR))  # a perfect camera still needs a little
    if np.linalg.eigvalsh(R)[0] <= 0.0:
        R = np.diag(np.diag(R))
    return R


class Mode:
    """The localizer interface: get_pose / set_pose (any subset of x, y, theta), fed by on_odom / on_fix."""

    sensors: tuple[str, ...] = ()  # the sensor topics the mode reads besides odom and fixes (on_imu, on_compass)

    def __init__(self, cfg: LocalizerConfig, robot: RobotConfig) -> None:
        self.cfg, self.robot = cfg, robot
        self.odom: m.Odom | None = None  # newest odometry sample used
        self.t_set = -math.inf  # [s] fixes captured before the last set_pose are ignored
        self.t_accepted: float | None = None  # [s] arrival of the last accepted fix
        self.correction = (0.0, 0.0, 0.0)  # moved by fixes between the previous odom sample and the newest
        self._pending = [0.0, 0.0, 0.0]  # corrections since the newest odom sample
        self._preset: tuple[float | None, ...] | None = None  # a set_pose that came before any odometry
        self._latencies: deque[float] = deque(maxlen=cfg.latency_window)
        self._recent_fixes: deque[tuple[float, float, float, float]] = deque(maxlen=DUPLICATE_WINDOW)  # (t, x, y, theta) of recent fixes
        self.latency_estimator = latency_estimator(cfg) if cfg.latency == "estimate" else None
        self.impacts = 0  # times the accelerometer found the wheels slipping (ekf)

    # ------------------------------------------------------------ interface
    @property
    def last(self) -> m.Odom:
        """The newest odometry sample: the mode's hooks run only once there is one."""
        if self.odom is None:
            raise RuntimeError("no odometry sample yet")
        return self.odom

    def on_odom(self, odom: m.Odom) -> str | None:
        """Integrate an odometry sample; returns why it was dropped (None: used)."""
        prev = self.odom
        if prev is not None and odom.t <= prev.t:
            return "stale"
        self.odom = odom
        if self.latency_estimator is not None:
            self.latency_estimator.on_odom(odom.t, odom.x, odom.y, odom.theta)
        c = self._pending
        self.correction, self._pending = (c[0], c[1], c[2]), [0.0, 0.0, 0.0]
        if prev is None:
            self._start(Pose2(odom.x, odom.y, wrap_angle(odom.theta)))
            if self._preset is not None:
                self._set(*self._preset)
            return None
        d = Pose2(prev.x, prev.y, prev.theta).between(Pose2(odom.x, odom.y, odom.theta))
        ds = math.copysign(math.hypot(d.x, d.y), d.x)  # [m] forward along the chord
        if abs(ds) > self.cfg.max_odom_step:
            # The odometry restarted: the chain goes on from this sample with no motion
            # over the jump (the fixes say where the robot went meanwhile).
            self._move(0.0, 0.0, prev.t, odom.t)
            return "jump"
        self._move(ds, d.theta, prev.t, odom.t)
        return None

    def on_fix(self, fix: m.VpsPose, t_arrival: float) -> m.Fix:
        """Use (or reject) a fix; returns its audit record."""
        key = (fix.t, fix.x, fix.y, fix.theta)
        est: Estimate | None = None
        if self.latency_estimator is not None:  # the capture time is arrival minus the estimated latency
            est = self.latency_estimator.on_fix(t_arrival, fix.x, fix.y, fix.theta)
            fix = msgspec.structs.replace(fix, t=max(0.0, t_arrival - est.latency))
        latency = t_arrival - fix.t
        self._latencies.append(latency)
        duplicate = key in self._recent_fixes
        self._recent_fixes.append(key)
        if duplicate:  # the same fix twice (a resent message): using it again would double its weight
            res = FixResult(False, "duplicate")
        elif self.odom is None:
            res = FixResult(False, "no_odom_yet")
        elif fix.t < self.t_set:
            res = FixResult(False, "before_set_pose")
        elif fix.t > self.odom.t + self.cfg.future_tolerance:
            res = FixResult(False, "future")
        else:
            before = self._estimate()[0]
            res = self._fix(fix, min(fix.t, self.odom.t), t_arrival)
            after = self._estimate()[0]
            delta = (after.x - before.x, after.y - before.y, wrap_angle(after.theta - before.theta))
            self._pending = [a + b for a, b in zip(self._pending, delta)]
            if res.accepted:
                self.t_accepted = t_arrival
        return m.Fix(
            t=fix.t,
            t_arrival=t_arrival,
            latency=latency,
            replay_depth=res.replay_depth,
            innovation=res.innovation,
            mahalanobis_d2=res.mahalanobis_d2,
            accepted=res.accepted,
            reason=res.reason,
            latency_estimate=None if est is None else est.latency,
            latency_sigma=None if est is None else est.sigma,
        )

    def on_imu(self, imu: m.Imu) -> str | None:
        """Take a gyro sample (a mode whose `sensors` name sensors/imu); returns why it was dropped."""
        return None

    def on_compass(self, compass: m.Compass) -> None:
        """Take a compass heading (a mode whose `sensors` name sensors/compass)."""

    def get_pose(self) -> m.Pose | None:
        """The estimate at the newest odom sample (None before any odometry)."""
        if self.odom is None:
            return None
        p, cov = self._estimate()
        o = self.odom
        return m.Pose(
            t=o.t,
            x=p.x,
            y=p.y,
            theta=p.theta,
            v=o.v,
            omega=o.omega,
            cov=cov,
            correction=self.correction,
            calibration=self.calibration(),
            slipping=self.slipping(),
        )

    def set_pose(self, t: float, x: float | None = None, y: float | None = None, theta: float | None = None) -> Pose2:
        """Reset any subset of the pose at time t; history cleared, older fixes ignored."""
        self.t_set = t
        given = (x, y, None if theta is None else wrap_angle(theta))
        if self.odom is None:  # keep it for the first odom sample, with any given before
            old = self._preset or (None, None, None)
            self._preset = tuple(o if n is None else n for n, o in zip(given, old))
            return Pose2(*(v or 0.0 for v in self._preset))
        self._set(*given)
        return self._estimate()[0]

    @property
    def latency(self) -> float | None:
        """[s] the VPS latency: median of arrival minus capture over recent fixes, or the online estimate."""
        if self.latency_estimator is not None:
            return self.latency_estimator.estimate.latency
        return statistics.median(self._latencies) if self._latencies else None

    def calibration(self) -> dict[str, float]:
        """Online estimates of the odometry's errors (empty: the mode has none)."""
        return {}

    def slipping(self) -> bool:
        """Whether the wheels are found slipping at the newest odom sample (False: the mode does not look)."""
        return False

    # ------------------------------------------------------------ a mode implements
    def _start(self, pose: Pose2) -> None:
        """The first odom sample: map = odom until a fix or set_pose says otherwise."""
        raise NotImplementedError

    def _move(self, ds: float, dth: float, t0: float, t: float) -> None:
        """One odom increment from t0 to t [s]: ds [m] forward, dth [rad]."""
        raise NotImplementedError

    def _fix(self, fix: m.VpsPose, t: float, t_arrival: float) -> FixResult:
        """Use a fix captured at t (no later than the newest odom sample)."""
        raise NotImplementedError

    def _set(self, x: float | None, y: float | None, theta: float | None) -> None:
        """Replace the given components of the estimate at the newest odom sample."""
        raise NotImplementedError

    def _estimate(self) -> tuple[Pose2, tuple[float, ...]]:
        """(pose, row-major 3x3 covariance) at the newest odom sample."""
        raise NotImplementedError
