"""Frames of the robot's own camera in, fixes out: the onboard VPS's pipeline without the bus.

A frame is decoded (refused when corrupt or not [onboard_camera]'s size), the [field] layout's tags detected in
it, and the robot's pose solved from them (onboard.solve), stamped with the frame's capture time at the tags' rows.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

from zenav.common import messages as m
from zenav.common.config import ConfigError, Settings
from zenav.common.onboardcam import OnboardCamera
from zenav.services.vps import detect, frames, onboard
from zenav.world.camera_time import row_time

SECTION = "onboard_camera"
TAG_PX = 24.0  # [px] tags are looked for on the frame halved: on the field's walls they stay over this size up to ~3.5 m


@dataclass(frozen=True)
class OnboardRead:
    """What one frame gave."""

    fix: m.VpsPose | None
    solved: onboard.TagFix | onboard.Refused | None  # None: no tag of the layout in the frame
    refused: str  # why the layout's tags in it gave no fix (onboard.Refused's reason), or ""
    unknown: int  # tags seen that are not in the layout
    detect_time: float  # [s] of the host's clock: decoding, detection, solving


class OnboardReader:
    """Reads the field's tags in frames of the robot's camera."""

    def __init__(self, settings: Settings, backend: detect.Backend = "auto") -> None:
        self.cfg = settings.section(SECTION, OnboardCamera)
        self.layout = {t.id: t for t in settings.field.tags}
        if not self.layout:
            raise ConfigError('[vps] source = "onboard" reads the [field] tags, and there are none: describe them (docs/onboard-camera.md)')
        self.detector = detect.make(backend, TAG_PX)

    def read(self, frame: m.CameraFrame, estimate: tuple[float, float, float] | None) -> OnboardRead:
        """The fix of a frame; FrameError when it is refused."""
        start = time.perf_counter()
        img = frames.decode(frame, self.cfg.width, self.cfg.height)
        found = self.detector.detect(img)
        solved = onboard.solve(found, self.layout, self.cfg, estimate)
        unknown = sum(1 for t in found if t.id not in self.layout)
        fix = None
        if isinstance(solved, onboard.TagFix):
            fix = m.VpsPose(t=self.stamp(frame.t, solved), x=solved.x, y=solved.y, theta=solved.theta, cov=solved.cov)
        refused = solved.reason if isinstance(solved, onboard.Refused) else ""
        return OnboardRead(fix, solved, refused, unknown, time.perf_counter() - start)

    def stamp(self, frame_t: float, solved: onboard.TagFix) -> float:
        """[s] when the fix's tags were exposed: a rolling shutter's rows after (or before) the frame's middle row."""
        cfg = self.cfg
        return max(frame_t + (row_time(solved.row, cfg.height, cfg.readout) if cfg.model != "ideal" else 0.0), 0.0)
