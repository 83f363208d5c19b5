"""A camera on the robot: where it is on the field, which of the field's tags it sees, and its frames.

    r = OnboardRenderer(cfg, tags, shapes, seed=1)
    img = r.render(x, y, theta, v, omega)  # H x W uint8, the camera of a robot at (x, y, theta) moving at (v, omega)

Pure: randomness from a generator seeded at construction, no clock. The robot stands on the floor (no pitch or
roll), so the horizon is fixed in the image: the background (floor below it, walls above) is drawn once. Each tag
the camera sees (in front of it, facing it, wholly in the frame, not wholly behind an obstacle) is drawn in
perspective: its printed image warped onto its projected outline, at twice the resolution then averaged down
(anti-aliased). Lens distortion moves the corners exactly; the edges between them are drawn straight. A wall or
field element between the camera and part of a tag hides that part (a grid of sight lines over the tag).
The robot's own motion: a rolling shutter (cfg.readout) sees each corner at its own row's time, and the exposure
(cfg.exposure) blurs the tag over the robot's travel during it (the mean of SAMPLES outlines).
World/camera_errors.py's `imperfect_onboard` gives the camera as it really is to render with.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import cast

import cv2
import msgspec
import numpy as np

from zenav.common.config import FieldTag
from zenav.common.field import Shape
from zenav.common.fieldtags import rotation
from zenav.common.onboardcam import OnboardCamera
from zenav.world.camera import TAG_CELLS, TAG_QUIET, Lens, Mount, project, tag_bitmap
from zenav.world.camera_time import row_time

BLACK, WHITE, FLOOR, WALL = 30.0, 220.0, 110.0, 170.0  # [grey levels]
CAMERA_AXES = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])  # camera x, y, z (columns) in the robot frame
NEAR = 0.05  # [m] a tag corner nearer the camera's image plane than this is not seen
EDGE_PX = 2.0  # [px] a tag's outline must stay this far inside the frame
OCCLUDER_GAP = 0.02  # [m] a tag's own wall does not hide it: the sight line stops this short of it
CELL_PX = 10  # [px] a printed cell in the image warped onto a tag
SUPERSAMPLE = 2  # each pixel of a tag drawn from 2 x 2 samples
RNG_STREAM = 0x4F4E42  # "ONB": the sensor noise's seed stream
SAMPLES = 5  # outlines averaged over a moving robot's exposure
SHUTTER_PASSES = 2  # a corner's row, then its place at that row's time: twice is within 0.01 px at robot speeds
SIGHT_GRID = 9  # sight lines across a partly hidden tag (each way)


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


def moved(x: float, y: float, theta: float, v: float, omega: float, dt: float) -> tuple[float, float, float]:
    """The pose dt [s] after (x, y, theta) [m, rad], driving at v [m/s] and turning at omega [rad/s] (an arc)."""
    mid = theta + omega * dt / 2.0
    return x + v * dt * float(np.cos(mid)), y + v * dt * float(np.sin(mid)), theta + omega * dt


def visible(eye: np.ndarray, points: np.ndarray, shapes: Sequence[Shape]) -> np.ndarray:
    """Whether each map point (N x 3) is in sight of eye (x, y) [m]: no obstacle on the floor between."""
    return np.array([not _hidden(eye, p[:2], shapes) for p in points], dtype=bool)


@dataclass(frozen=True)
class Sighting:
    """One tag the camera sees, and its outline in the image."""

    tag: FieldTag
    corners: np.ndarray  # 4 x 2 [px] the black square's corners, top-left first, as the lens shows them
    distance: float  # [m] camera to the tag's centre


def sightings(cfg: OnboardCamera, cam: Mount, tags: Sequence[FieldTag], shapes: Sequence[Shape]) -> list[Sighting]:
    """The tags a camera at `cam` sees: in front of it, facing it, wholly inside the frame, not wholly hidden."""
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
        if all(_hidden(cam.C[:2], p[:2], shapes) for p in (centre, *pts)):
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

    def render(self, x: float, y: float, theta: float, v: float = 0.0, omega: float = 0.0) -> np.ndarray:
        """The frame of the robot at (x, y, theta) [m, rad] at the frame's stamp (the middle row, mid exposure),
        driving at v [m/s] and turning at omega [rad/s] (H x W, uint8 grey levels)."""
        cam = mount(self.cfg, x, y, theta)
        img = self.background.copy()
        moving = v != 0.0 or omega != 0.0
        shutter = [0.0]
        if moving and self.cfg.exposure > 0.0:
            shutter = list(np.linspace(-0.5, 0.5, SAMPLES) * self.cfg.exposure)
        for s in sightings(self.cfg, cam, self.tags, self.shapes):
            outer = _outer(s.tag)
            outlines = [self._outline(outer, moved(x, y, theta, v, omega, dt), v, omega) for dt in shutter]
            self._draw(img, outlines, s.tag, self._sight(cam, outer))
        if self.cfg.noise > 0.0:
            start = int(self.rng.integers(0, self.noise.size - img.size))
            img += self.noise[start : start + img.size].reshape(img.shape)
        return cast(np.ndarray, np.clip(img, 0.0, 255.0).astype(np.uint8))

    def _outline(self, tag: FieldTag, pose: tuple[float, float, float], v: float, omega: float) -> np.ndarray:
        """4 x 2 [px] the tag's corners, each where the camera saw it when its row was exposed (rolling shutter)."""
        lo, pts = lens(self.cfg), tag.corners()
        px = project(lo, mount(self.cfg, *pose), pts)
        if self.cfg.readout <= 0.0 or (v == 0.0 and omega == 0.0):
            return px
        for _ in range(SHUTTER_PASSES):
            dts = row_time(px[:, 1], self.cfg.height, self.cfg.readout)
            px = np.vstack([project(lo, mount(self.cfg, *moved(*pose, v, omega, float(dt))), p[None]) for p, dt in zip(pts, dts)])
        return px

    def _sight(self, cam: Mount, tag: FieldTag) -> np.ndarray | None:
        """SIGHT_GRID x SIGHT_GRID: which parts of the tag (its white border too) are in sight; None: all of it."""
        if not self.shapes:
            return None
        a = (np.arange(SIGHT_GRID) + 0.5) / SIGHT_GRID - 0.5  # across the tag, in units of its size
        r = rotation(tag.yaw, tag.pitch, tag.roll)
        u, w = np.meshgrid(a, a)  # u: the tag's left to right as seen facing it; w: top to bottom
        pts = np.array([tag.x, tag.y, tag.z]) + tag.size * (np.outer(u.ravel(), r[:, 1]) - np.outer(w.ravel(), r[:, 2]))
        seen = visible(cam.C[:2], pts, self.shapes).reshape(SIGHT_GRID, SIGHT_GRID)
        return None if seen.all() else seen.astype(np.float32)

    def _draw(self, img: np.ndarray, outlines: Sequence[np.ndarray], tag: FieldTag, seen: np.ndarray | None) -> None:
        """Warp one printed tag (its white border too) onto its outlines (the mean of them: the blur) in img; the parts
        not `seen` show the obstacle in front (a wall's grey)."""
        h, w = img.shape
        box = np.vstack(outlines)
        u0, v0 = np.maximum(np.floor(box.min(axis=0)).astype(int) - 1, 0)
        u1, v1 = np.minimum(np.ceil(box.max(axis=0)).astype(int) + 2, (w, h))
        if u0 >= u1 or v0 >= v1:
            return
        printed = self._printed_tag(tag.id)
        n = float(printed.shape[0])
        sight = np.ones_like(printed) if seen is None else cv2.resize(seen, printed.shape[::-1], interpolation=cv2.INTER_NEAREST)
        # Pixel centres at whole numbers: the printed image's edges at -0.5 and n - 0.5, onto the outline's corners.
        src = np.array([[0.0, 0.0], [n, 0.0], [n, n], [0.0, n]], np.float32) - 0.5
        size = ((u1 - u0) * SUPERSAMPLE, (v1 - v0) * SUPERSAMPLE)
        layers = [np.zeros((size[1], size[0]), np.float32) for _ in range(3)]  # tag, cover, the tag's part in sight
        for px in outlines:
            dst = ((px - (u0, v0) + 0.5) * SUPERSAMPLE - 0.5).astype(np.float32)
            hom = cv2.getPerspectiveTransform(src, dst)
            for acc, source in zip(layers, (printed * sight, np.ones_like(printed), sight)):
                acc += cv2.warpPerspective(source, hom, size, flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)
        tag_img, cover, shown = (cv2.resize(a / len(outlines), (u1 - u0, v1 - v0), interpolation=cv2.INTER_AREA) for a in layers)
        under = img[v0:v1, u0:u1]
        under[...] = tag_img + (cover - shown) * WALL + (1.0 - cover) * under


def _outer(tag: FieldTag) -> FieldTag:
    """The tag's printed square, its white border included."""
    grow = (TAG_CELLS + 2 * TAG_QUIET) / TAG_CELLS
    return msgspec.structs.replace(tag, size=tag.size * grow)
