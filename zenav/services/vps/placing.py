"""A located tag as a fix: when its row was exposed, and how far the camera's own errors may have put it.

Pure. A rolling shutter exposes the image row by row over its `readout`: a tag low in
the image was seen later than one high in it, so each fix is stamped with its own row's
time (the frame's stamp is the middle row's). Its covariance, from the tag's corners
and the calibration (locate.py), is widened by what the corners cannot show, from the
[camera] error sizes: the lens off its calibration (calibration_error px, as metres on
the tag's plane), the mount's shake (vibration rad at the camera's height above the tag),
and the tag's height off tag_height (tag_height_error, moving the fix along the ray,
radially from the point under the camera). An `ideal` camera adds nothing.
"""

from __future__ import annotations

import math

import numpy as np

from zenav.common import messages as m
from zenav.common.config import Camera
from zenav.services.vps.locate import Sighting
from zenav.world.camera_time import row_time


def stamp(frame_t: float, s: Sighting, cfg: Camera) -> float:
    """[s] on the frame's clock: when the tag's row was exposed (an ideal camera's all at once)."""
    return frame_t + (row_time(s.row, cfg.height, cfg.readout) if cfg.model != "ideal" else 0.0)


def widen(s: Sighting, cfg: Camera) -> tuple[float, ...]:
    """The sighting's covariance (3x3 row-major) with the camera's own errors added."""
    cov = np.array(s.cov, dtype=np.float64).reshape(3, 3)
    if cfg.model == "ideal":
        return tuple(float(v) for v in cov.ravel())
    depth = max(cfg.z - cfg.tag_height, 1e-3)  # [m] camera above the tag's plane
    lens = cfg.calibration_error * depth / cfg.fx  # [m] on the plane
    shake = cfg.vibration * depth  # [m]
    cov[:2, :2] += np.eye(2) * (lens**2 + shake**2)
    dx, dy = s.x - cfg.x, s.y - cfg.y
    r = math.hypot(dx, dy)
    if r > 0.0:
        along = cfg.tag_height_error * r / depth  # [m] a tag dh higher moves dh * r / depth towards the nadir
        u = np.array([dx, dy]) / r
        cov[:2, :2] += np.outer(u, u) * along**2
    cov[2, 2] += cfg.vibration**2
    return tuple(float(v) for v in cov.ravel())


def fix(s: Sighting, t: float, cfg: Camera) -> m.VpsPose:
    """The fix of a sighting, stamped t [s] on the stack clock."""
    return m.VpsPose(t=t, x=s.x, y=s.y, theta=s.theta, cov=widen(s, cfg))
