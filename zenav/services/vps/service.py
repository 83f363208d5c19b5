"""The VPS service: late fixes on `vps/pose`, from the world model's overhead camera (zenav.world.vps), the field camera's
frames, or the robot's own camera's frames."""

from __future__ import annotations

import statistics
from collections import deque
from typing import TYPE_CHECKING, Annotated, Literal

import msgspec
from msgspec import Meta, Struct

from zenav.common import codec, extras, keys
from zenav.common import messages as m
from zenav.common.bus import Bus
from zenav.common.client import Sampled
from zenav.common.clock import Clock
from zenav.common.config import Camera as CameraConfig
from zenav.common.config import Settings
from zenav.common.runtime import Duplicate, Service, timer
from zenav.services.vps.clocks import SYNC_PERIOD, HostClock
from zenav.services.vps.detect import Backend
from zenav.services.vps.frames import FrameError, check_fits
from zenav.world import faults
from zenav.world.vps import Camera, Delivery, DeliveryQueue, make_rng

if TYPE_CHECKING:  # the camera's modules need OpenCV: imported when the camera is on
    from zenav.services.vps.calibration import Calibration
    from zenav.services.vps.onboard_reader import OnboardReader
    from zenav.services.vps.reader import Reader

TIMING_WINDOW = 50  # frames whose median pipeline and detection times diag reports
INPUT_SILENT = 1.0  # [s] truth or frames heard before and silent this long: status error (no fixes)
TAG_UNSEEN = 1.0  # [s] frames coming but this robot's tag not located this long: status degraded
ESTIMATE_SIGMA = 0.1  # [m] a pose whose position is less sure than this resolves no ambiguous tag
STALE = 1.0  # [s] a frame or truth sample stamped further behind the stack clock is refused (its fix would come too late)


class VpsConfig(Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """The [vps] section (the synthetic camera's errors are the scenario's; the real one is [camera])."""

    stamp: Literal["capture", "none"] = "capture"  # a fix's t: its capture time, or (none) the time it is sent
    # synthetic: sim/truth plus the scenario's errors; camera: robot tags in the overhead camera's frames; onboard: the
    # [field] tags in the frames of the robot's own camera ([onboard_camera])
    source: Literal["synthetic", "camera", "onboard"] = "synthetic"
    detector: Backend = "auto"  # the camera's tag detector: apriltag (pupil-apriltags), opencv, or auto (apriltag if installed)
    # "": the robot's vps; a name: one more camera's vps beside it, running as vps_<name> (its own alive, instance and diag
    # keys), its fixes on the same vps/pose, each stamped at its capture: the localizer fuses them all
    name: Annotated[str, Meta(pattern=r"^[a-z0-9_]{0,32}$")] = ""
    # more cameras' vps that `zenav up` starts beside this one, one process per source, each named after it (vps_onboard,
    # vps_camera): "camera" or "onboard", not this one's own source
    also: tuple[Literal["camera", "onboard"], ...] = ()

    def __post_init__(self) -> None:
        if self.source in self.also or len(set(self.also)) < len(self.also):
            raise ValueError(f"also = {list(self.also)}: each a source other than this vps's own ({self.source}), once")
        if self.source != "synthetic":  # at start, in one line, rather than when the first frame comes
            extras.check("cv2", f'the camera VPS ([vps] source = "{self.source}")')
            if self.detector == "apriltag":
                extras.check("pupil_apriltags", 'the AprilTag detector ([vps] detector = "apriltag"; or "opencv")')


class Vps(Service):
    """Publishes each fix after its latency: sampled from `sim/truth` at the scenario's VPS rate (synthetic),
    read from every frame on zenav/field/camera/frame for every robot in [camera] robots (camera), or solved from
    the [field] tags in the frames of the robot's own camera on camera/onboard/frame (onboard)."""

    name = "vps"
    config_type = VpsConfig
    health_period = 0.5  # [s] how often a silent input or an unseen tag is looked for

    def __init__(self, settings: Settings, bus: Bus, clock: Clock) -> None:
        super().__init__(settings, bus, clock)
        if self.cfg.name:
            self.name = f"vps_{self.cfg.name}"  # a second camera's vps: its own presence, beside the robot's vps
        self.camera = Camera(self.settings.scenario, make_rng(self.settings.deployment.seed))
        self.queues: dict[str, DeliveryQueue] = {self.robot: DeliveryQueue()}
        self._heard: float | None = None  # [s] clock time the newest truth sample or frame came
        self._seen = 0.0  # [s] clock time this robot's tag was last located (camera)
        self.reader: Reader | None = None
        self.host: HostClock | None = None  # the camera host's clock and its sync to each robot's stack (camera)
        self.onboard: OnboardReader | None = None
        self._pose: Sampled | None = None  # the localizer's 100 Hz pose, kept by the bus unserved: read as a frame comes
        if self.cfg.source == "camera":
            self.blocking = True  # a frame takes milliseconds to detect ...
            self.background = True  # ... and the control loop must not wait for a core meanwhile
            from zenav.services.vps import calibration_file, detect
            from zenav.services.vps.reader import Reader
            from zenav.world.camera import tag_pixels

            cam = self.settings.section("camera", CameraConfig)
            check_fits(cam, self.limits)
            self.reader = Reader(cam, calibration_file.configured(cam), detect.make(self.cfg.detector, tag_pixels(cam)))
            self.queues = {robot: DeliveryQueue() for robot in cam.robots}
            self.host = HostClock(cam, self.clock, self.bus, self.settings.deployment.seed)
        if self.cfg.source == "onboard":
            self.blocking = self.background = True  # as the camera's: detection takes milliseconds
            from zenav.services.vps.onboard_reader import OnboardReader

            self.onboard = OnboardReader(self.settings, self.cfg.detector)
            self.link_delay = self.onboard.cfg.link_delay  # [s] (the overhead camera's: its host's clock, self.host)
        if self.cfg.source != "synthetic":
            self.timing: dict[str, deque[float]] = {k: deque(maxlen=TIMING_WINDOW) for k in ("pipeline_ms_p50", "detect_ms_p50")}

    def on_start(self) -> None:
        if self.onboard is not None:
            self.subscribe("camera/onboard/frame", m.CameraFrame, self.on_onboard_frame, latest=True)
            self._pose = self.newest("pose")
        elif self.reader is None:
            self.subscribe("sim/truth", m.Truth, self.on_truth)
        else:
            self._claim_robots()
            # A detector slower than the camera reads the newest frame each time, not one ever older. Frames are
            # stamped on the camera host's clock, not this stack's: no stamp of theirs is judged against the stack's.
            self.subscribe("camera/frame", m.CameraFrame, self.on_frame, latest=True, other_clock=True)
            self.sync_clocks(self.clock.now())

    def _claim_robots(self) -> None:
        """Every robot this camera serves besides its own must have no other vps (its own stack's, or another
        camera's), or its localizer would get two streams of fixes: Duplicate, naming it, if one runs. Each then
        gets this instance's token, `zenav/<robot>/instance/vps/<id>`, which a vps starting for it finds and
        refuses to run beside, as it would beside a vps of its own robot."""
        others = [robot for robot in self.queues if robot != self.robot]  # its own: the runtime's check
        for robot in others:
            names = self.running_for(robot)
            if names is not None:
                raise Duplicate(
                    f"[camera] robots has {robot}, for which another vps already runs ({names}): stop that vps, or take"
                    f" {robot} out of [camera] robots here"
                )
        for robot in others:
            self._handles.append(self.bus.token(keys.key(robot, f"instance/vps/{self.instance}")))

    def on_clock_reset(self) -> None:
        """The sim restarted (a new instance owns the clock): the fixes still pending are of its previous run."""
        for q in self.queues.values():
            self.count("fixes_voided", len(q))
            q.clear()
        if self.host is not None:
            self.host.forget()
        if self._pose is not None:
            self._pose.forget()

    @timer(SYNC_PERIOD)
    def sync_clocks(self, now: float) -> None:
        """Ask each robot's stack for its clock (time/sync); take in the replies that came meanwhile."""
        if self.host is None:
            return
        self._synced()
        self.host.ask()

    def _behind(self, t: float) -> float | None:
        """[s] how far a stamp is behind the stack clock, when that is more than STALE (else None)."""
        behind = self.clock.now() - t
        return behind if self.clock.ready and behind > STALE else None

    def on_truth(self, msg: m.Truth) -> None:
        """One truth sample: a capture when one is due."""
        behind = self._behind(msg.t)
        if behind is not None:
            self.count("dropped_stale")
            self.warn("stale", f"dropped sim/truth stamped t={msg.t:.3f}, {behind:.3f} s behind the stack clock")
            return
        self._heard = self.clock.now()
        d = self.camera.capture(msg)
        if d is not None:
            self._hold(self.robot, d)

    def on_frame(self, msg: m.CameraFrame) -> None:
        """One camera frame: each robot tag in it becomes a fix on its stack's clock, sent after the link delay."""
        from zenav.services.vps import placing  # OpenCV's (through locate): imported once the camera is on

        assert self.reader is not None and self.host is not None
        self._synced()
        host_now = self.host.now()
        behind = host_now - msg.t
        try:
            if self.clock.ready and abs(behind) > STALE:
                raise FrameError(f"stamped t={msg.t:.3f}, {behind:.3f} s behind the camera host's clock (more than {STALE:g} s either way)")
            got = self.reader.read(msg)
        except FrameError as e:
            self.count("frames_refused")
            self.warn("frame", f"refused a camera frame: {e}")
            return
        now = self.clock.now()
        if self._heard is None:
            self._seen = now  # the tag's absence counts from the first frame
        self._heard = now
        if got.uncalibrated:
            self.count("frames_uncalibrated")
            self.set_status("error", f"cannot calibrate the camera: {got.uncalibrated}")
            return
        if got.calibrated is not None:
            self._calibrated(got.calibrated)
        self.count("frames")
        self.count("tags_unknown", got.located.unknown)
        self.count("tags_duplicate", got.located.duplicates)
        self.count("tags_wrong_size", got.located.wrong_size)
        for s in got.located.fixes:
            t = self.host.to_stack(s.robot, placing.stamp(msg.t, s, self.reader.cfg))
            if t is None:
                self.count("fixes_unsynced")
                self.warn("unsynced", f"no fix for {s.robot}: its stack has not told its clock yet (time/sync)")
                continue
            self._hold(s.robot, Delivery(now + self.host.link_delay(), msg.seq, placing.fix(s, max(t, 0.0), self.reader.cfg)))
            if s.robot == self.robot:
                self._seen = now
        self._timing(host_now - msg.t, got.detect_time)  # exposure's middle to detection done, host clock
        self.reader.explore()  # the frame's periodic whole search, its fixes out

    @property
    def estimate(self) -> tuple[float, float, float] | None:
        """[m, m, rad] the localizer's newest pose, what an ambiguous single tag is resolved against, while its position
        is sure enough (None: not sure, or none came)."""
        msg = self._pose.msg if self._pose is not None else None
        if msg is None or msg.cov[0] + msg.cov[4] >= ESTIMATE_SIGMA**2:
            return None
        return (msg.x, msg.y, msg.theta)

    def on_onboard_frame(self, msg: m.CameraFrame) -> None:
        """One frame of the robot's camera: the [field] tags in it become one fix, sent after the link delay."""
        assert self.onboard is not None
        behind = self._behind(msg.t)
        try:
            if behind is not None:
                raise FrameError(f"stamped t={msg.t:.3f}, {behind:.3f} s behind the stack clock (more than {STALE:g} s)")
            got = self.onboard.read(msg, self.estimate)
        except FrameError as e:
            self.count("frames_refused")
            self.warn("frame", f"refused a camera frame: {e}")
            return
        self._heard = now = self.clock.now()
        self.count("frames")
        self.count("tags_unknown", got.unknown)
        if got.refused:
            self.count(f"fixes_refused_{got.refused}")
            self.warn(f"refused_{got.refused}", f"no fix from this frame: {getattr(got.solved, 'detail', '')}")
        if got.fix is not None:
            self._hold(self.robot, Delivery(now + self.link_delay, msg.seq, got.fix))
            self._seen = now
        self._timing(now - msg.t, got.detect_time)  # exposure to detection done, stack clock

    def _timing(self, pipeline: float, detect: float) -> None:
        """Add one frame's times [s] to the medians diag reports."""
        self.timing["pipeline_ms_p50"].append(pipeline * 1e3)
        self.timing["detect_ms_p50"].append(detect * 1e3)
        for name, window in self.timing.items():
            self.counters.values[name] = round(statistics.median(window))

    def _synced(self) -> None:
        """Take in the clock replies that came since the last look; count and log the refused ones."""
        assert self.host is not None
        for refused in self.host.take_replies():
            self.count("sync_refused")
            self.warn("sync", f"time/sync reply refused: {refused}")
        for robot, sync in self.host.syncs.items():
            if sync.ready:
                self.counters.values[f"clock_offset_us_{robot}"] = round(sync.offset * 1e6)

    def _calibrated(self, cal: Calibration) -> None:
        """A calibration fitted to the frames' fixed tags ([camera] calibration = "auto")."""
        self.counters.values["calibration_rms_um"] = round(cal.rms * 1e6)
        self.log.info(
            "camera calibrated from fixed tags %s: corner residual %.2f mm rms, camera %.3f m above the floor",
            list(cal.anchors),
            cal.rms * 1e3,
            cal.camera_height(),
        )

    @timer("health_period")
    def check_health(self, now: float) -> None:
        """Error while the input (truth or frames), heard before, is silent; degraded while frames come without this robot's tag."""
        if self._heard is None:
            return
        what = "sim/truth sample" if self.cfg.source == "synthetic" else "camera frame"
        if now - self._heard > INPUT_SILENT:
            self.set_status("error", f"no {what} for {now - self._heard:.1f} s: no fixes")
        elif self.reader is not None and self.reader.cal is not None and now - self._seen > TAG_UNSEEN:
            tag = self.reader.cfg.robots.get(self.robot)
            why = f"tag {tag} not seen for {now - self._seen:.1f} s" if tag is not None else "no tag in [camera] robots"
            self.set_status("degraded", f"robot {self.robot}: {why}")
        elif self.reader is None or self.reader.cal is not None:
            self.set_status("ok")

    def _hold(self, robot: str, d: Delivery) -> None:
        """Hold a fix until its delivery time, when `deliver` runs."""
        self.queues[robot].push(d)
        self.count("fixes_captured")
        self.call_at(d.t_delivery, self.deliver)

    def deliver(self, now: float) -> None:
        """Publish every fix whose delivery time has come."""
        for robot, queue in self.queues.items():
            for d in queue.pop_due(now):
                fx = faults.at(self.settings.scenario, d.fix.t if self.cfg.stamp == "capture" else now)
                fix = msgspec.structs.replace(d.fix, t=fx.stamp)
                for _ in range(fx.copies):
                    if robot == self.robot:
                        self.publish("vps/pose", fix)
                    else:
                        self.bus.publish(keys.key(robot, "vps/pose"), codec.encode(fix))
                        self.count("msgs_out")
