"""The sim's onboard camera: frames of what a camera on the robot ([onboard_camera]) sees of the [field] tags."""

from __future__ import annotations

import numpy as np

from zenav.common import messages as m
from zenav.common.config import Settings
from zenav.common.onboardcam import OnboardCamera
from zenav.services.sim.camera import Cadence
from zenav.world.camera_errors import dropped, imperfect_onboard, jpeg, shake, tags_as_placed
from zenav.world.onboard import OnboardRenderer

SECTION = "onboard_camera"
RNG_STREAM = 0x4F5348  # "OSH": the chassis' shake and the frames lost


class OnboardFrames:
    """Frames of the robot's own camera at [onboard_camera] rate_hz, each of the truth at its time. The camera has a
    real one's errors ([onboard_camera] model, world/camera_errors.py): rendered through the true lens and mount
    among the tags as placed, rolled and blurred by the robot's motion, shaken, some lost, sent as JPEG."""

    def __init__(self, settings: Settings) -> None:
        cfg = settings.section(SECTION, OnboardCamera)
        seed = settings.deployment.seed
        self.errors = imperfect_onboard(cfg, seed)
        tags = tags_as_placed(cfg, settings.field.tags, seed)
        self.renderer = OnboardRenderer(self.errors.true, tags, settings.field.shapes(), seed)
        self.rng = np.random.default_rng([seed, RNG_STREAM])
        self.exposure = self.errors.true.exposure
        self.due = Cadence(cfg.rate_hz).due
        self.seq = 0
        self.lost = 0  # frames lost on the way (drop_rate)

    def frame(self, truth: m.Truth) -> m.CameraFrame | None:
        """The frame whose exposure is centred on truth.t; None: lost on the way."""
        img = shake(self.renderer.render(truth.x, truth.y, truth.theta, truth.v, truth.omega), self.errors, self.rng)
        self.seq += 1
        if dropped(self.errors, self.rng):
            self.lost += 1
            return None
        h, w = img.shape
        q = self.errors.jpeg_quality
        if q > 0:
            return m.CameraFrame(t=truth.t, seq=self.seq, width=w, height=h, encoding="jpeg", exposure=self.exposure, data=jpeg(img, q))
        return m.CameraFrame(t=truth.t, seq=self.seq, width=w, height=h, exposure=self.exposure, data=img.tobytes())
