"""The localizer service: odometry and late VPS fixes in, the pose in the map frame out."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from zenav.common import keys
from zenav.common import messages as m
from zenav.common.bus import Bus, Query
from zenav.common.clock import Clock
from zenav.common.config import Settings
from zenav.common.contract import ErrorCode
from zenav.common.runtime import QueryError, Service, publish, query, subscribe, timer

from .base import LocalizerConfig
from .modes import make_mode

OUTLIERS_DEGRADED = 3  # fixes rejected in a row that make the status degraded
GYRO_SILENT = 0.5  # [s] a gyro that was heard and is silent this long makes the status degraded
ODOM_SILENT = 1.0  # [s] odometry heard before and silent this long: status error (the pose is not updated)


class Localizer(Service):
    """Publishes `pose` for every odom sample and an audit record for every fix."""

    name = "localizer"
    config_type = LocalizerConfig
    cfg: LocalizerConfig
    health_period = 0.5  # [s] how often the diag status is re-evaluated

    def __init__(self, settings: Settings, bus: Bus, clock: Clock) -> None:
        super().__init__(settings, bus, clock)
        self.mode = make_mode(self.cfg, self.settings.robot)
        self.newest_fix: float | None = None  # [s] latest capture time received
        self.outliers_in_row = 0  # fixes rejected as outliers since the last accepted one
        self.last_imu: float | None = None  # [s] stack time the newest gyro sample arrived

    def on_clock_reset(self) -> None:
        """The sim restarted: the world and its odometry start again, and so does the estimate."""
        self.mode = make_mode(self.cfg, self.settings.robot)
        self.newest_fix, self.outliers_in_row, self.last_imu = None, 0, None

    @subscribe("odom")
    @publish("pose")
    def on_odom(self, msg: m.Odom) -> m.Pose | None:
        """One odom sample: the pose at its t."""
        impacts = self.mode.impacts
        dropped = self.mode.on_odom(msg)
        if self.mode.impacts > impacts:
            self.count("impacts")
            self.warn(
                "impact",
                f"the accelerometer and the odometry part at t={msg.t:.3f} (a wall, a robot, a push, an encoder that stopped"
                " counting?): the wheels slip. With every start and stop, check the accelerometer's axis and sign; with"
                " every turn, [robot] imu_x and imu_y; or set [localizer] impact_speed = 0",
            )
        if dropped == "stale":
            self.count("dropped_stale")
            self.warn("odom_stale", f"odom t={msg.t:.3f} is not after the previous sample: dropped")
            return None
        if dropped == "jump":
            self.count("odom_jumps")
            self.warn("odom_jump", f"odom jumped at t={msg.t:.3f} (odometry restarted?): continuing from it")
        return self.mode.get_pose()

    def on_start(self) -> None:
        # Sensor topics are subscribed only when the configured mode reads them.
        handlers: dict[str, Callable[[Any], Any]] = {"sensors/imu": self.on_imu, "sensors/compass": self.on_compass}
        for suffix in self.mode.sensors:
            self.subscribe(suffix, keys.TOPICS[suffix], handlers[suffix])

    def on_imu(self, msg: m.Imu) -> None:
        """One gyro sample (modes that read the gyro). One for a time whose pose is already out
        is late: the ekf re-integrates the steps it covers, the other modes go on without it."""
        odom = self.mode.odom
        if self.mode.on_imu(msg) == "stale":
            self.count("dropped_stale")
        elif odom is not None and msg.t <= odom.t:
            self.count("gyro_late")
        self.last_imu = self.clock.now()

    def on_compass(self, msg: m.Compass) -> None:
        """One compass heading (modes that read the compass)."""
        self.mode.on_compass(msg)

    # A late fix re-integrates the history since its capture (milliseconds on a small computer):
    # it is applied in the gap after the next odom sample, so that no sample's chain waits for it.
    @subscribe("vps/pose", after="odom")
    @publish("localizer/fixes")
    def on_fix(self, msg: m.VpsPose) -> m.Fix:
        """One VPS fix: its audit record."""
        if self.newest_fix is not None and msg.t < self.newest_fix:
            self.count("fixes_out_of_order")  # applied at its capture time all the same
        self.newest_fix = msg.t if self.newest_fix is None else max(self.newest_fix, msg.t)
        rec = self.mode.on_fix(msg, self.arrived())
        self.count(f"fixes_{rec.reason}")
        if rec.reason == "duplicate":
            self.warn("duplicate", f"dropped a second VPS fix captured at t={msg.t:.3f}")
        if rec.accepted:
            self.outliers_in_row = 0
        elif rec.reason == "outlier":
            self.outliers_in_row += 1
        return rec

    @query("localizer/pose", acts=False)
    def get_pose(self, req: m.Empty, q: Query) -> m.LocalizerPoseReply:
        """getPose: the newest estimate, its calibration and the measured VPS latency."""
        p = self.mode.get_pose()
        if p is None:
            raise QueryError(ErrorCode.UNAVAILABLE, "no odometry received yet")
        return m.LocalizerPoseReply(t=p.t, x=p.x, y=p.y, theta=p.theta, cov=p.cov, calibration=p.calibration, vps_latency=self.mode.latency)

    @query("time/sync", acts=False)
    def time_sync(self, req: m.Empty, q: Query) -> m.ClockReply:
        """The stack's clock now, for a camera host that measures its own against it (the camera vps)."""
        return m.ClockReply(t=self.clock.now())

    @query("localizer/set_pose")
    def set_pose(self, req: m.SetPose, q: Query) -> m.PoseStamped:
        """setPose / setPosition / setHeading: any subset of x, y, theta but none, from now on."""
        if req.x is None and req.y is None and req.theta is None:
            raise QueryError(ErrorCode.INVALID_ARGUMENT, m.SET_POSE_EMPTY)
        now = self.clock.now()
        p = self.mode.set_pose(now, req.x, req.y, req.theta)
        self.log.info("set_pose x=%s y=%s theta=%s at t=%.3f", req.x, req.y, req.theta, now)
        t = self.mode.odom.t if self.mode.odom is not None else now
        return m.PoseStamped(t=t, x=p.x, y=p.y, theta=p.theta)

    @timer("health_period")
    def check_health(self, now: float) -> None:
        """Error while the odometry is silent; degraded while no fix is accepted, the gyro is silent or fixes keep
        disagreeing; report an odd latency."""
        notes = []
        latency = self.mode.latency
        if latency is not None:
            est = self.mode.latency_estimator
            sigma = "" if est is None else f" +/- {est.estimate.sigma:.3f} s estimated"
            notes.append(f"vps latency {latency:.3f} s{sigma}")
            expected = self.cfg.expected_latency
            if abs(latency - expected) > self.cfg.latency_tolerance:
                notes.append(f"expected {expected:.3f} s")
                self.warn("latency", f"measured VPS latency {latency:.3f} s, config expects {expected:.3f} s")
        status = "ok"
        if self.cfg.mode != "dead_reckoning":
            last = self.mode.t_accepted
            if last is None:
                status = "degraded"
                notes.insert(0, "no VPS fix accepted yet")
            elif now - last > self.cfg.stale_fix:
                status = "degraded"
                notes.insert(0, f"no VPS fix accepted for {now - last:.1f} s")
            if self.last_imu is not None and now - self.last_imu > GYRO_SILENT:
                status = "degraded"
                notes.insert(0, f"no gyro sample for {now - self.last_imu:.1f} s: heading from the odometry")
            if self.outliers_in_row >= OUTLIERS_DEGRADED:
                status = "degraded"
                notes.insert(0, f"{self.outliers_in_row} VPS fixes in a row disagree with the odometry")
            if self.mode.slipping():
                status = "degraded"
                notes.insert(0, "the wheels slip (held by a wall or a robot, pushed?): the position rests on the fixes")
        odom = self.mode.odom
        if odom is not None and now - odom.t > ODOM_SILENT:
            status = "error"
            notes.insert(0, f"no odometry for {now - odom.t:.1f} s: the pose is not updated")
        self.set_status(status, "; ".join(notes))
