"""Frames in, fixes out: the camera VPS's pipeline without the bus.

A frame is decoded (refused when corrupt or not the configured size), its tags
detected, and each robot tag located through the calibration; every fix is stamped
with the frame's capture time. A reader given no calibration fits one to the fixed
tags of the first frame that shows enough of them ([camera] calibration = "auto").
"""

from __future__ import annotations

import time
from dataclasses import dataclass

from zenav.common import messages as m
from zenav.common.config import Camera
from zenav.services.vps import detect, frames, locate
from zenav.services.vps.calibration import Calibration, CalibrationError, calibrate
from zenav.world.camera import tag_pixels


@dataclass(frozen=True)
class Read:
    """What one frame gave."""

    fixes: list[tuple[str, m.VpsPose]]  # (robot id, fix) for every robot located
    located: locate.Located
    detect_time: float  # [s] of the host's clock: decoding, detection, location
    calibrated: Calibration | None = None  # the calibration fitted to this frame's fixed tags (auto)
    uncalibrated: str = ""  # why no calibration could be fitted yet (auto): this frame gave no fixes


class Reader:
    """Reads the robots' tags in frames of one calibrated camera."""

    def __init__(self, cfg: Camera, cal: Calibration | None, detector: detect.Detector | None = None) -> None:
        """`cal` None: fit the calibration to the fixed tags of the frames as they come."""
        if cal is not None and (cal.lens.width, cal.lens.height) != (cfg.width, cfg.height):
            raise CalibrationError(
                f"the calibration is for {cal.lens.width}x{cal.lens.height} frames, [camera] says {cfg.width}x{cfg.height}:"
                " run `zenav camera calibrate` again"
            )
        self.cfg, self.cal = cfg, cal
        self.detector = detector or detect.make("auto", tag_pixels(cfg))
        self.anchors = {a.id for a in cfg.anchors}

    def read(self, frame: m.CameraFrame) -> Read:
        """The fixes in a frame; FrameError when it is refused."""
        start = time.perf_counter()
        img = frames.decode(frame, self.cfg.width, self.cfg.height)
        c = self.cfg
        tags = self.detector.detect(img)
        fitted = None
        if self.cal is None:
            try:
                self.cal = fitted = calibrate(tags, c)
            except CalibrationError as e:
                return Read([], locate.Located(), time.perf_counter() - start, uncalibrated=str(e))
        found = locate.locate(tags, self.cal, c.robots, self.anchors, c.tag_size, c.tag_height, c.corner_sigma)
        fixes = [(s.robot, m.VpsPose(t=frame.t, x=s.x, y=s.y, theta=s.theta, cov=s.cov)) for s in found.fixes]
        return Read(fixes, found, time.perf_counter() - start, calibrated=fitted)
