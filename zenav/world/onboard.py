"""A camera on the robot: where it is on the field, which of the field's tags it sees, and its frames.

    r = OnboardRenderer(cfg, tags, shapes, seed=1)
    img = r.render(x, y, theta)  # H x W uint8, the camera of a robot at (x, y, theta)

Pure: randomness from a generator seeded at construction, no clock. The robot stands on the floor (no pitch or
roll), so the horizon is fixed in the image: the background (floor below it, walls above) is drawn once. Each tag
the camera sees (in front of it, facing it, wholly in the frame, no obstacle between) is drawn in perspective:
its printed image warped onto its projected outline, at twice the resolution then averaged down (anti-aliased).
Lens distortion moves the corners exactly; the edges between them are drawn straight.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import cast

import cv2
import numpy as np

from zenav.common.config import FieldTag
from zenav.common.field import Shape
from zenav.common.fieldtags import rotation
from zenav.common.onboardcam import OnboardCamera
from zenav.world.camera import TAG_CELLS, TAG_QUIET, Lens, Mount, project, tag_bitmap

BLACK, WHITE, FLOOR, WALL = 30.0, 220.0, 110.0, 170.0  # [grey levels]
CAMERA_AXES = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])  # camera x, y, z (columns) in the robot frame
NEAR = 0.05  # [m] a tag corner nearer the camera's image plane than this is not seen
EDGE_PX = 2.0  # [px] a tag's outline must stay this far inside the frame
OCCLUDER_GAP = 0.02  # [m] a tag's own wall does not hide it: the sight line stops this short of it
CELL_PX = 10  # [px] a printed cell in the image warped onto a tag
SUPERSAMPLE = 2  # each pixel of a tag drawn from 2 x 2 samples
RNG_STREAM = 0x4F4E42  # "ONB": the sensor noise's seed stream


def lens(cfg: OnboardCamera) -> Lens:
    """The lens [onboard_camera] describes."""
    cx, cy = cfg.principal
    K = np.array([[cfg.fx, 0.0, cx], [0.0, cfg.fy, cy], [0.0, 0.0, 1.0]])
    return Lens(K, np.array([cfg.k1, cfg.k2, cfg.p1, cfg.p2, cfg.k3]), cfg.width, cfg.height)


def robot_to_camera(cfg: OnboardCamera) -> tuple[np.ndarray, np.ndarray]:
    """(R, t): camera-frame directions to robot-frame ones (3x3), and the optical centre in the robot frame [m]."""
    return rotation(cfg.yaw, cfg.pitch, cfg.roll) @ CAMERA_AXES, np.array([cfg.x, cfg.y, cfg.z])


def mount(cfg: OnboardCamera, x: float, y: float, theta: float) -> Mount:
    """Where the camera is on the field when the robot is at (x, y, theta) [m, rad]."""
    r, t = robot_to_camera(cfg)
    body = rotation(theta)
    return Mount((body @ r).T, np.array([x, y, 0.0]) + body @ t)


@dataclass(frozen=True)
class Sighting:
    """One tag the camera sees, and its outline in the image."""

    tag: FieldTag
    corners: np.ndarray  # 4 x 2 [px] the black square's corners, top-left first, as the lens shows them
    distance: float  # [m] camera to the tag's centre


def sightings(cfg: OnboardCamera, cam: Mount, tags: Sequence[FieldTag], shapes: Sequence[Shape]) -> list[Sighting]:
    """The tags a camera at `cam` sees wholly: in front of it, facing it, inside the frame, no obstacle between."""
    lo, out = lens(cfg), []
    for tag in tags:
        centre = np.array([tag.x, tag.y, tag.z])
        to_cam = cam.C - centre
        if float(to_cam @ rotation(tag.yaw, tag.pitch, tag.roll)[:, 0]) <= 0.0:
            continue  # seen from behind, or edge on
        pts = tag.corners()
        if np.any((cam.R @ (pts - cam.C).T)[2] < NEAR):
            continue
        px = project(lo, cam, pts)
        if np.any(px < EDGE_PX) or np.any(px[:, 0] > cfg.width - 1 - EDGE_PX) or np.any(px[:, 1] > cfg.height - 1 - EDGE_PX):
            continue
        if _hidden(cam.C[:2], centre[:2], shapes):
            continue
        out.append(Sighting(tag, px, float(np.linalg.norm(to_cam))))
    return out


def _hidden(eye: np.ndarray, target: np.ndarray, shapes: Sequence[Shape]) -> bool:
    """Whether an obstacle stands on the floor between eye and target (map x, y [m])."""
    d = float(np.linalg.norm(target - eye))
    if d <= OCCLUDER_GAP:
        return False
    end = target - (target - eye) * OCCLUDER_GAP / d
    a, b = (float(eye[0]), float(eye[1])), (float(end[0]), float(end[1]))
    return any(s.segment_clearance(a, b) <= 0.0 for s in shapes)


class OnboardRenderer:
    """Frames of a robot's camera among the field's tags."""

    def __init__(self, cfg: OnboardCamera, tags: Sequence[FieldTag], shapes: Sequence[Shape], seed: int) -> None:
        self.cfg, self.tags, self.shapes = cfg, tuple(tags), tuple(shapes)
        self.rng = np.random.default_rng([seed, RNG_STREAM])
        h, w = cfg.height, cfg.width
        self.noise = self.rng.standard_normal(2 * h * w, dtype=np.float32) * np.float32(cfg.noise)
        self.background = self._background()
        self._printed: dict[int, np.ndarray] = {}

    def _background(self) -> np.ndarray:
        """Floor below the horizon, walls above (the robot stands level: the horizon never moves in the image)."""
        cfg = self.cfg
        v, u = np.mgrid[0 : cfg.height, 0 : cfg.width].astype(np.float64)
        pts = lens(cfg).undistort(np.stack([u.ravel(), v.ravel()], axis=1))
        k = lens(cfg).K
        ideal = np.stack([(pts[:, 0] - k[0, 2]) / k[0, 0], (pts[:, 1] - k[1, 2]) / k[1, 1], np.ones(len(pts))])
        up = (robot_to_camera(cfg)[0] @ ideal)[2].reshape(cfg.height, cfg.width)  # ray's rise, robot frame
        return cast(np.ndarray, np.where(up < 0.0, FLOOR - 20.0 * np.tanh(-4.0 * up), WALL + 10.0 * np.tanh(4.0 * up)).astype(np.float32))

    def _printed_tag(self, tag_id: int) -> np.ndarray:
        if tag_id not in self._printed:
            cells = BLACK + (WHITE - BLACK) * tag_bitmap(tag_id)
            self._printed[tag_id] = np.kron(cells, np.ones((CELL_PX, CELL_PX), np.float32)).astype(np.float32)
        return self._printed[tag_id]

    def render(self, x: float, y: float, theta: float) -> np.ndarray:
        """The frame of the robot at (x, y, theta) [m, rad] (H x W, uint8 grey levels)."""
        cam = mount(self.cfg, x, y, theta)
        img = self.background.copy()
        for s in sightings(self.cfg, cam, self.tags, self.shapes):
            self._draw(img, cam, s.tag)
        if self.cfg.noise > 0.0:
            start = int(self.rng.integers(0, self.noise.size - img.size))
            img += self.noise[start : start + img.size].reshape(img.shape)
        return cast(np.ndarray, np.clip(img, 0.0, 255.0).astype(np.uint8))

    def _draw(self, img: np.ndarray, cam: Mount, tag: FieldTag) -> None:
        """Warp one printed tag (its white border too) onto its outline in img."""
        grow = (TAG_CELLS + 2 * TAG_QUIET) / TAG_CELLS
        outer = FieldTag(id=tag.id, size=tag.size * grow, x=tag.x, y=tag.y, z=tag.z, yaw=tag.yaw, pitch=tag.pitch, roll=tag.roll)
        px = project(lens(self.cfg), cam, outer.corners())
        h, w = img.shape
        u0, v0 = np.maximum(np.floor(px.min(axis=0)).astype(int) - 1, 0)
        u1, v1 = np.minimum(np.ceil(px.max(axis=0)).astype(int) + 2, (w, h))
        if u0 >= u1 or v0 >= v1:
            return
        printed = self._printed_tag(tag.id)
        n = float(printed.shape[0])
        # Pixel centres at whole numbers: the printed image's edges at -0.5 and n - 0.5, onto the outline's corners.
        src = np.array([[0.0, 0.0], [n, 0.0], [n, n], [0.0, n]], np.float32) - 0.5
        dst = ((px - (u0, v0) + 0.5) * SUPERSAMPLE - 0.5).astype(np.float32)
        hom = cv2.getPerspectiveTransform(src, dst)
        size = ((u1 - u0) * SUPERSAMPLE, (v1 - v0) * SUPERSAMPLE)
        tag_img = cv2.warpPerspective(printed, hom, size, flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)
        cover = cv2.warpPerspective(np.ones_like(printed), hom, size, flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)
        tag_img = cv2.resize(tag_img, (u1 - u0, v1 - v0), interpolation=cv2.INTER_AREA)
        cover = cv2.resize(cover, (u1 - u0, v1 - v0), interpolation=cv2.INTER_AREA)
        under = img[v0:v1, u0:u1]
        under[...] = cover * tag_img + (1.0 - cover) * under
