"""Frames in, fixes out: the camera VPS's pipeline without the bus.

A frame is decoded (refused when corrupt or not the configured size), its tags
detected, and each robot tag located through the calibration; every fix is stamped
with the frame's capture time. A reader given no calibration fits one to the fixed
tags of the first frame that shows enough of them ([camera] calibration = "auto").
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from zenav.common import messages as m
from zenav.common.config import Camera
from zenav.services.vps import detect, frames, locate, track
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

    def __init__(self, cfg: Camera, cal: Calibration | None, detector: detect.Detector | None = None, windowed: bool = True) -> None:
        """`cal` None: fit the calibration to the fixed tags of the frames as they come. `windowed`: once calibrated,
        look for each robot's tag in a window round its predicted place (track.py), else always in the whole frame."""
        if cal is not None and (cal.lens.width, cal.lens.height) != (cfg.width, cfg.height):
            raise CalibrationError(
                f"the calibration is for {cal.lens.width}x{cal.lens.height} frames, [camera] says {cfg.width}x{cfg.height}:"
                " run `zenav camera calibrate` again"
            )
        self.cfg, self.cal = cfg, cal
        self.detector = detector or detect.make("auto", tag_pixels(cfg))
        self.anchors = {a.id for a in cfg.anchors}
        self.tracker = track.Tracker(cfg.width, cfg.height, cfg.tag_size) if windowed else None
        self.whole = 0  # frames searched whole (the others: in windows)
        self._due: tuple[np.ndarray, float] | None = None  # the last frame, when due a whole search after its fixes

    def read(self, frame: m.CameraFrame) -> Read:
        """The fixes in a frame; FrameError when it is refused."""
        start = time.perf_counter()
        img = frames.decode(frame, self.cfg.width, self.cfg.height)
        c = self.cfg
        tags = self._tags(img, frame.t)
        fitted = None
        if self.cal is None:
            try:
                self.cal = fitted = calibrate(tags, c)
            except CalibrationError as e:
                return Read([], locate.Located(), time.perf_counter() - start, uncalibrated=str(e))
        found = locate.locate(tags, self.cal, c.robots, self.anchors, c.tag_size, c.tag_height, c.corner_sigma)
        fixes = [(s.robot, m.VpsPose(t=frame.t, x=s.x, y=s.y, theta=s.theta, cov=s.cov)) for s in found.fixes]
        return Read(fixes, found, time.perf_counter() - start, calibrated=fitted)

    def _tags(self, img: np.ndarray, t: float) -> list[detect.Tag]:
        """The tags in a frame: in the robots' windows when they are all there, else in the whole frame. A frame
        due a whole search (track.FULL_PERIOD) whose robots are all in their windows is kept for `explore`."""
        ids = self.cfg.robots.values()
        windows = self.tracker.windows(t, ids) if self.tracker is not None and self.cal is not None else None
        if windows is not None and self.tracker is not None:
            tags = detect.unique([tag for w in windows for tag in self._detect_in(img, w)])  # windows may overlap
            if not self.tracker.lost(tags, ids):
                self.tracker.update(t, tags, ids, full=False)
                self._due = (img, t) if self.tracker.due(t) else None
                return tags
        return self._whole(img, t)

    def _whole(self, img: np.ndarray, t: float) -> list[detect.Tag]:
        self.whole += 1
        tags = self.detector.detect(img)
        if self.tracker is not None:
            self.tracker.update(t, tags, self.cfg.robots.values(), full=True)
        return tags

    def explore(self) -> None:
        """The whole search of the last frame read, if it was due one and gave its fixes from windows: robots that
        came into view are followed from the next frame on. Called once the frame's fixes are out."""
        if self._due is not None:
            img, t = self._due
            self._due = None
            self._whole(img, t)

    def _detect_in(self, img: np.ndarray, w: track.Window) -> list[detect.Tag]:
        """The tags in one window of a frame, in the frame's pixels."""
        x0, y0, x1, y1 = w
        offset = np.array([x0, y0], dtype=np.float64)
        return [detect.Tag(t.id, t.corners + offset, t.margin) for t in self.detector.detect(img[y0:y1, x0:x1])]
