"""The overhead camera's geometry: intrinsics, lens distortion, mounting, and projection.

Pure: a pinhole camera with OpenCV's distortion model, mounted above the floor
looking down. The map frame has z up; with yaw = tilt = 0 the image x axis runs
along map +x and the image y axis along map -y (the image reads like a map).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import cast

import cv2
import numpy as np

from zenav.common.config import Camera

# 36h11 tags: 6 x 6 data cells inside a one-cell black border, inside a one-cell white border.
TAG_CELLS = 8  # cells across the black square (the tag size)
TAG_QUIET = 1  # white cells around it, part of the printed tag


@dataclass(frozen=True)
class Lens:
    """Intrinsics and distortion, in OpenCV's conventions."""

    K: np.ndarray  # 3x3 camera matrix [px]
    dist: np.ndarray  # (k1, k2, p1, p2, k3)
    width: int  # [px]
    height: int  # [px]

    @classmethod
    def of(cls, cfg: Camera) -> Lens:
        """The lens a [camera] config describes."""
        cx, cy = cfg.principal
        K = np.array([[cfg.fx, 0.0, cx], [0.0, cfg.fy, cy], [0.0, 0.0, 1.0]])
        return cls(K, np.array([cfg.k1, cfg.k2, cfg.p1, cfg.p2, cfg.k3]), cfg.width, cfg.height)

    def undistort(self, px: np.ndarray) -> np.ndarray:
        """Pixel points (N x 2) as an ideal pinhole camera with the same K would see them."""
        pts = np.asarray(px, dtype=np.float64).reshape(-1, 1, 2)
        crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 20, 1e-9)  # the default 5 iterations leave ~0.1 px
        return cv2.undistortPoints(pts, self.K, self.dist, P=self.K, criteria=crit).reshape(-1, 2)


@dataclass(frozen=True)
class Mount:
    """Where the camera hangs: map-to-camera rotation R and the optical centre C [m]."""

    R: np.ndarray  # 3x3, camera = R @ (map - C)
    C: np.ndarray  # (x, y, z) [m] map frame

    @classmethod
    def of(cls, cfg: Camera) -> Mount:
        """The mounting a [camera] config describes."""
        c, s = math.cos(cfg.yaw), math.sin(cfg.yaw)
        down = np.array([[c, s, 0.0], [s, -c, 0.0], [0.0, 0.0, -1.0]])  # looking straight down, turned by yaw
        ct, st = math.cos(cfg.tilt), math.sin(cfg.tilt)
        tilt = np.array([[1.0, 0.0, 0.0], [0.0, ct, -st], [0.0, st, ct]])
        return cls(tilt @ down, np.array([cfg.x, cfg.y, cfg.z]))


def project(lens: Lens, mount: Mount, pts: np.ndarray) -> np.ndarray:
    """Map points (N x 3) [m] -> pixels (N x 2), distorted as the camera sees them."""
    rvec, _ = cv2.Rodrigues(mount.R)
    tvec = -mount.R @ mount.C
    out, _ = cv2.projectPoints(np.asarray(pts, dtype=np.float64).reshape(-1, 1, 3), rvec, tvec, lens.K, lens.dist)
    return out.reshape(-1, 2)


def pixel_rays(lens: Lens, mount: Mount, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Map-frame directions (... x 3) of the rays through pixels (u, v), distortion undone."""
    pts = lens.undistort(np.stack([u.ravel(), v.ravel()], axis=1))
    ideal = np.linalg.solve(lens.K, np.vstack([pts.T, np.ones(len(pts))]))  # normalised camera coordinates
    rays = (mount.R.T @ ideal).T
    return cast(np.ndarray, rays.reshape(*u.shape, 3))


def plane_hits(mount: Mount, rays: np.ndarray, z: float) -> tuple[np.ndarray, np.ndarray]:
    """(x, y) [m] where rays from the camera meet the horizontal plane at height z [m]."""
    s = (z - mount.C[2]) / rays[..., 2]
    return mount.C[0] + s * rays[..., 0], mount.C[1] + s * rays[..., 1]


def tag_bitmap(tag_id: int) -> np.ndarray:
    """A tag36h11 as printed: (8 + 2) x (8 + 2) cells, 0 black and 1 white, row 0 at the top."""
    aruco = cv2.aruco
    inner = aruco.generateImageMarker(aruco.getPredefinedDictionary(aruco.DICT_APRILTAG_36h11), tag_id, TAG_CELLS)
    return np.pad(inner > 127, TAG_QUIET, constant_values=True).astype(np.float32)


def tag_pixels(cfg: Camera) -> float:
    """[px] edge of a robot's tag right under the camera."""
    return cfg.tag_size * cfg.fx / max(cfg.z - cfg.tag_height, 1e-3)
