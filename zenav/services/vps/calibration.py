"""Pixels to the field: a floor homography fitted to the fixed tags, corrected for height.

Pure. The corners of the fixed tags (known map positions) are undistorted with the
lens's intrinsics, then a homography maps undistorted pixels to the floor (x, y). A
robot's tag sits `h` above the floor: the floor homography, factored with the
intrinsics into the camera's rotation and translation, gives the homography of the
plane at height h. A camera looking down sees tags parallel to the image plane, where
a 6-DoF PnP pose is ambiguous; the plane homography gives x, y and yaw robustly.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from zenav.common.config import Camera, ConfigError
from zenav.services.vps.detect import Tag
from zenav.world.camera import Lens

MIN_ANCHORS = 2  # fixed tags a calibration needs (4 corners each)
VERSION = 1


class CalibrationError(ConfigError):
    """A calibration that cannot be made or read; the message says what to do (a service given none exits as on bad config)."""


def square(x: float, y: float, size: float) -> np.ndarray:
    """Corners (4 x 2) [m] of a tag centred at (x, y), sides along x and y: top-left, top-right, bottom-right, bottom-left."""
    s = size / 2.0
    return np.array([(x - s, y + s), (x + s, y + s), (x + s, y - s), (x - s, y - s)])


def _apply(H: np.ndarray, pts: np.ndarray) -> np.ndarray:
    return cv2.perspectiveTransform(np.asarray(pts, dtype=np.float64).reshape(-1, 1, 2), H).reshape(-1, 2)


@dataclass(frozen=True)
class Calibration:
    """The lens and the floor homography of one mounted camera."""

    lens: Lens
    floor: np.ndarray  # 3x3: undistorted pixel -> floor (x, y) [m]
    rms: float  # [m] residual of the fixed tags' corners
    anchors: tuple[int, ...]  # ids of the fixed tags it was fitted to

    def plane(self, h: float) -> np.ndarray:
        """3x3 homography: undistorted pixel -> (x, y) [m] on the horizontal plane h [m] above the floor."""
        R, t = self.pose()
        G = self.lens.K @ np.column_stack([R[:, 0], R[:, 1], t + h * R[:, 2]])  # plane -> pixel
        return np.linalg.inv(G)

    def pose(self) -> tuple[np.ndarray, np.ndarray]:
        """(R, t): the camera's rotation and translation (camera = R @ map + t), from the floor homography."""
        M = np.linalg.solve(self.lens.K, np.linalg.inv(self.floor))  # ~ [r1 r2 t] up to scale
        scale = 2.0 / (np.linalg.norm(M[:, 0]) + np.linalg.norm(M[:, 1]))
        if M[2, 2] < 0:  # the floor is in front of the camera
            scale = -scale
        r1, r2, t = M[:, 0] * scale, M[:, 1] * scale, M[:, 2] * scale
        r3 = np.cross(r1, r2)
        u, _, vt = np.linalg.svd(np.column_stack([r1, r2, r3 / np.linalg.norm(r3)]))
        return u @ vt, t  # the nearest rotation

    def camera_height(self) -> float:
        """[m] the optical centre above the floor, as the calibration places it."""
        R, t = self.pose()
        return float(-(R.T @ t)[2])

    def to_plane(self, px: np.ndarray, h: float) -> np.ndarray:
        """Pixels as seen (N x 2, distorted) -> (x, y) [m] on the plane h [m] above the floor."""
        return _apply(self.plane(h) if h else self.floor, self.lens.undistort(px))

    def to_json(self) -> dict[str, Any]:
        """The calibration as the file `zenav camera calibrate` writes."""
        return {
            "version": VERSION,
            "width": self.lens.width,
            "height": self.lens.height,
            "camera_matrix": self.lens.K.tolist(),
            "distortion": self.lens.dist.tolist(),
            "floor_homography": self.floor.tolist(),
            "rms_m": self.rms,
            "anchors": list(self.anchors),
            "camera_height_m": self.camera_height(),
        }

    @classmethod
    def from_json(cls, d: Any) -> Calibration:
        """The calibration `to_json` gave; ValueError, KeyError or TypeError when it is not one."""
        if not isinstance(d, dict):
            raise ValueError(f"a {type(d).__name__}, not an object")
        if d.get("version") != VERSION:
            raise ValueError(f"version {d.get('version')!r}, expected {VERSION}")
        lens = Lens(np.array(d["camera_matrix"], float), np.array(d["distortion"], float), int(d["width"]), int(d["height"]))
        floor = np.array(d["floor_homography"], float)
        if lens.K.shape != (3, 3) or floor.shape != (3, 3) or lens.dist.shape != (5,):
            raise ValueError("matrix shapes")
        return cls(lens, floor, float(d["rms_m"]), tuple(int(a) for a in d["anchors"]))


def calibrate(tags: list[Tag], cfg: Camera) -> Calibration:
    """Fit the floor homography to the fixed tags ([camera] anchors, anchor_size) seen in one frame, through cfg's lens."""
    lens, size = Lens.of(cfg), cfg.anchor_size
    known = {a.id: a for a in cfg.anchors}
    seen = [t for t in tags if t.id in known]
    ids = sorted({t.id for t in seen})
    if len(ids) != len(seen):
        raise CalibrationError("a fixed tag is seen twice: each id in [camera] anchors must be printed once")
    if len(seen) < MIN_ANCHORS:
        missing = sorted(set(known) - set(ids))
        raise CalibrationError(f"calibration needs {MIN_ANCHORS} fixed tags in view, saw {len(seen)} (missing ids {missing})")
    px = lens.undistort(np.vstack([t.corners for t in seen]))
    field = np.vstack([square(known[t.id].x, known[t.id].y, size) for t in seen])
    H, _ = cv2.findHomography(px, field, 0)
    if H is None:
        raise CalibrationError("the fixed tags' corners fit no homography (are they collinear?)")
    residual = _apply(H, px) - field
    rms = float(np.sqrt(np.mean(np.sum(residual**2, axis=1))))
    return Calibration(lens, H, rms, tuple(ids))
