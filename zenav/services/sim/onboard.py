"""The sim's onboard camera: frames of what a camera on the robot ([onboard_camera]) sees of the [field] tags."""

from __future__ import annotations

from zenav.common import messages as m
from zenav.common.config import Settings
from zenav.common.onboardcam import OnboardCamera
from zenav.services.sim.camera import Cadence
from zenav.world.onboard import OnboardRenderer

SECTION = "onboard_camera"


class OnboardFrames:
    """Frames of the robot's own camera at [onboard_camera] rate_hz, each of the truth at its time."""

    def __init__(self, settings: Settings) -> None:
        cfg = settings.section(SECTION, OnboardCamera)
        self.renderer = OnboardRenderer(cfg, settings.field.tags, settings.field.shapes(), settings.deployment.seed)
        self.due = Cadence(cfg.rate_hz).due
        self.seq = 0
        self.lost = 0  # frames lost on the way: none, the robot's own camera is on its own computer

    def frame(self, truth: m.Truth) -> m.CameraFrame:
        """The frame whose (instant) exposure is at truth.t."""
        img = self.renderer.render(truth.x, truth.y, truth.theta)
        self.seq += 1
        h, w = img.shape
        return m.CameraFrame(t=truth.t, seq=self.seq, width=w, height=h, data=img.tobytes())
