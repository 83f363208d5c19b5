"""The overhead camera's own errors, as a real camera has them.

    e = imperfect(cfg, seed=1)          # drawn once per camera: the lens, mount and tags as they really are
    r = Renderer(e.true, seed=1, readout=e.readout)
    img = shake(r.render(t, bodies), e, rng)  # per frame: the mount's vibration

Pure: randomness from the generators passed in or seeded here. What [camera] configures
is what the vps believes (the calibrated lens, the measured tag height, the nominal tag
size); `imperfect` draws the camera that really is, off by the configured error sizes:
- the lens: the true intrinsics and distortion differ from the calibrated ones, so that
  the calibrated model misplaces points by `calibration_error` px rms over the image;
- the mount: tilted and turned by `mount_tilt` off the configured tilt and yaw (fitting the
  floor to the fixed tags absorbs it), and shaken by `vibration` rad (1 sigma) each frame;
- the tags: each robot's at a height off tag_height by `tag_height_error` (1 sigma), all
  printed at a scale off 1 by `print_scale_error` (one printer: one draw for all);
- the rest are per frame: the rolling shutter's `readout`, JPEG's `jpeg_quality`, frames
  lost (`drop_rate`), and the camera host's clock (`clock_offset`, `clock_drift`).
`model = "ideal"` keeps every one of these at zero but the host's clock.

The robot's own camera ([onboard_camera]) has the same lens, shake, print scale, shutter, JPEG and losses
(`imperfect_onboard`); its mount is off in pitch and yaw, and the field's tags stand off their layout by
`tag_position_error` (`tags_as_placed`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Generic, TypeVar

import cv2
import msgspec
import numpy as np

from zenav.common.config import Camera, FieldTag
from zenav.common.onboardcam import OnboardCamera
from zenav.world.camera_time import host_time

RNG_STREAM = 0x455252  # "ERR": the camera's drawn errors' seed stream
# Scale of each intrinsic's share of a unit lens error: fx, fy [relative], cx, cy [px], k1, k2 (OpenCV's model)
LENS_SHARES = (0.004, 0.004, 1.5, 1.5, 0.01, 0.005)
GRID = 9  # pixels across (and 3/4 as many down) where the lens error's rms is measured

C = TypeVar("C", Camera, OnboardCamera)  # either camera: both have OpenCV's lens model and a frame size


@dataclass(frozen=True)
class Imperfect(Generic[C]):
    """The camera as it really is, and its per-frame errors' sizes."""

    true: C  # the lens, mount and tags the frames are rendered with
    readout: float  # [s] rolling shutter: top row to bottom row
    vibration: float  # [rad] 1 sigma per frame, about each axis
    jpeg_quality: int  # 0: raw
    drop_rate: float  # fraction of frames lost
    clock_offset: float  # [s] the camera host's clock ahead of the stack's
    clock_drift: float  # [ppm]

    def host_time(self, t: float) -> float:
        """The camera host's clock [s] when the stack's reads t."""
        return host_time(t, self.clock_offset, self.clock_drift)


def lens_error_px(believed: C, true: C) -> float:
    """[px] rms over the image of where the true lens images a ray minus where the believed one places it."""
    w, h = believed.width, believed.height
    u, v = np.meshgrid(np.linspace(0.05, 0.95, GRID) * w, np.linspace(0.05, 0.95, GRID * 3 // 4) * h)
    px = np.stack([u.ravel(), v.ravel()], axis=1).reshape(-1, 1, 2)
    K_b, d_b = _lens(believed)
    K_t, d_t = _lens(true)
    rays = cv2.undistortPoints(px, K_b, d_b).reshape(-1, 2)
    pts = np.hstack([rays, np.ones((len(rays), 1))]).reshape(-1, 1, 3)
    seen, _ = cv2.projectPoints(pts, np.zeros(3), np.zeros(3), K_t, d_t)
    return float(np.sqrt(np.mean(np.sum((seen.reshape(-1, 2) - px.reshape(-1, 2)) ** 2, axis=1))))


def _lens(c: Camera | OnboardCamera) -> tuple[np.ndarray, np.ndarray]:
    cx, cy = c.principal
    return np.array([[c.fx, 0.0, cx], [0.0, c.fy, cy], [0.0, 0.0, 1.0]]), np.array([c.k1, c.k2, c.p1, c.p2, c.k3])


def _lens_off(cfg: C, draw: np.ndarray, rms_px: float) -> C:
    """cfg's lens moved along the direction `draw` (6 normal values) so far that it is off by rms_px [px] rms."""
    cx, cy = cfg.principal

    def moved(s: float) -> C:
        d = draw * np.array(LENS_SHARES) * s
        return msgspec.structs.replace(
            cfg, fx=cfg.fx * (1 + d[0]), fy=cfg.fy * (1 + d[1]), cx=cx + d[2], cy=cy + d[3], k1=cfg.k1 + d[4], k2=cfg.k2 + d[5]
        )

    if rms_px <= 0.0:
        return cfg
    unit = lens_error_px(cfg, moved(1.0))  # nearly linear at these sizes
    return moved(rms_px / unit) if unit > 0 else cfg


def imperfect(cfg: Camera, seed: int) -> Imperfect[Camera]:
    """The camera [camera] describes as it really is, drawn for a seed (the same seed, the same camera)."""
    clock = (cfg.clock_offset, cfg.clock_drift)
    if cfg.model == "ideal":
        return Imperfect(cfg, 0.0, 0.0, 0, 0.0, *clock)
    rng = np.random.default_rng([seed, RNG_STREAM])
    true = _lens_off(cfg, rng.standard_normal(6), cfg.calibration_error)
    turn = rng.uniform(-math.pi, math.pi)  # the direction the mount leans
    scale = 1.0 + cfg.print_scale_error * rng.standard_normal()
    true = msgspec.structs.replace(
        true,
        tilt=cfg.tilt + cfg.mount_tilt * math.cos(turn),
        yaw=cfg.yaw + cfg.mount_tilt * math.sin(turn),
        tag_height=max(0.0, cfg.tag_height + cfg.tag_height_error * rng.standard_normal()),
        tag_size=cfg.tag_size * scale,
        anchor_size=cfg.anchor_size * scale,
    )
    return Imperfect(true, cfg.readout, cfg.vibration, cfg.jpeg_quality, cfg.drop_rate, *clock)


def imperfect_onboard(cfg: OnboardCamera, seed: int) -> Imperfect[OnboardCamera]:
    """The robot's camera [onboard_camera] describes as it really is, drawn for a seed. Its true `readout` and
    `exposure` are what the renderer rolls and blurs over (0 for an ideal camera); the host's clock is the stack's."""
    if cfg.model == "ideal":
        return Imperfect(msgspec.structs.replace(cfg, readout=0.0, exposure=0.0), 0.0, 0.0, 0, 0.0, 0.0, 0.0)
    rng = np.random.default_rng([seed, RNG_STREAM])
    true = _lens_off(cfg, rng.standard_normal(6), cfg.calibration_error)
    turn = rng.uniform(-math.pi, math.pi)
    true = msgspec.structs.replace(true, pitch=cfg.pitch + cfg.mount_tilt * math.cos(turn), yaw=cfg.yaw + cfg.mount_tilt * math.sin(turn))
    return Imperfect(true, cfg.readout, cfg.vibration, cfg.jpeg_quality, cfg.drop_rate, 0.0, 0.0)


def tags_as_placed(cfg: OnboardCamera, tags: Sequence[FieldTag], seed: int) -> tuple[FieldTag, ...]:
    """The field's tags as they really are: each centre off its layout by tag_position_error (1 sigma, each axis),
    all printed at one scale off 1 by print_scale_error. An ideal camera's are the layout's."""
    if cfg.model == "ideal":
        return tuple(tags)
    rng = np.random.default_rng([seed, RNG_STREAM, 1])
    scale = 1.0 + cfg.print_scale_error * rng.standard_normal()
    out = []
    for t in tags:
        dx, dy, dz = rng.standard_normal(3) * cfg.tag_position_error
        out.append(msgspec.structs.replace(t, size=t.size * scale, x=t.x + dx, y=t.y + dy, z=t.z + dz))
    return tuple(out)


def shake(img: np.ndarray, e: Imperfect[Camera] | Imperfect[OnboardCamera], rng: np.random.Generator) -> np.ndarray:
    """The frame as the shaken mount saw it: turned by e.vibration (1 sigma, rad) about each axis, drawn from rng."""
    if e.vibration <= 0.0:
        return img
    rx, ry, rz = rng.standard_normal(3) * e.vibration
    c = e.true
    M = cv2.getRotationMatrix2D(c.principal, math.degrees(rz), 1.0)
    M[:, 2] += (c.fx * ry, c.fy * rx)  # a small turn about an image axis moves the image across the other
    return cv2.warpAffine(img, M, (img.shape[1], img.shape[0]), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)


def dropped(e: Imperfect[Camera] | Imperfect[OnboardCamera], rng: np.random.Generator) -> bool:
    """Whether this frame is lost on the way (one draw a frame, lost or not)."""
    return bool(rng.random() < e.drop_rate)


def jpeg(img: np.ndarray, quality: int) -> bytes:
    """The grey frame compressed as a camera's JPEG of that quality (1..100)."""
    ok, buf = cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    if not ok:
        raise ValueError(f"cannot encode a {img.shape[1]}x{img.shape[0]} frame as JPEG")
    return buf.tobytes()
