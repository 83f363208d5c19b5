"""The overhead camera's frames, rendered from the truth.

    r = Renderer(cfg, seed=1)
    img = r.render(t, [Body(tag=0, x=0.3, y=0.2, theta=0.5, v=0.2, omega=0.0)])  # H x W uint8

Pure: time comes in as t, randomness from a generator seeded at construction. The
floor, its grid and the fixed tags are drawn once (each pixel averaged over 2 x 2
samples); per frame only the pixels around each robot are drawn again (3 x 3 samples
per pixel, at several instants of the exposure for the motion blur, each row at its own
time with a rolling shutter's `readout`; a robot standing still over the same floor is
the same pixels again, drawn once), then the light
(a swing over time and a gradient across the field, with vignetting) and the sensor
noise are applied to the whole image, a band of rows at a time. About 2.6 ms of CPU a
640x480 frame with two robots moving (the frames of `zenav bench camera`, which times them
with the mount's shake and the JPEG).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple, cast

import numpy as np

from zenav.common.config import Camera
from zenav.world.camera import TAG_CELLS, Lens, Mount, pixel_rays, plane_hits, project, tag_bitmap
from zenav.world.camera_time import row_time

BLACK, WHITE, FLOOR, BODY = 30.0, 220.0, 150.0, 80.0  # [grey levels] under the nominal light
GRID = 0.5  # [m] spacing of the lines drawn on the floor
GRID_WIDTH = 0.01  # [m]
RNG_STREAM = 0x43414D  # "CAM": the sensor noise's seed stream
MAX_BLUR_STEPS = 8  # instants of the exposure a moving robot is drawn at, at most
BAND = 128  # [rows] the frame is lit and cast a band at a time: the band's working images stay in the cache
SUB = (-1.0 / 3.0, 0.0, 1.0 / 3.0)  # [px] where across a pixel (each way) a robot is sampled


@dataclass(frozen=True)
class Body:
    """One robot as the camera sees it: its tag id and its motion at the frame's time."""

    tag: int
    x: float  # [m] map frame
    y: float  # [m]
    theta: float  # [rad]
    v: float = 0.0  # [m/s] forward
    omega: float = 0.0  # [rad/s]


def _square(bitmap: np.ndarray, u: np.ndarray, v: np.ndarray, cell: float) -> tuple[np.ndarray, np.ndarray]:
    """(inside, value) of a printed tag sampled at tag-frame points u (right), v (up) [m]."""
    half = bitmap.shape[0] / 2.0
    col = np.floor(u / cell + half).astype(np.int32)
    row = np.floor(half - v / cell).astype(np.int32)
    n = bitmap.shape[0]
    inside = (col >= 0) & (col < n) & (row >= 0) & (row < n)
    value = bitmap[np.clip(row, 0, n - 1), np.clip(col, 0, n - 1)]
    return inside, value


def pose_at(b: Body, tau: Any) -> tuple[Any, Any, Any]:
    """(x, y, theta) of a body tau [s] (a number or an array) after its stamp, at constant twist."""
    th = b.theta + b.omega * tau
    mid = b.theta + b.omega * tau / 2.0  # chord direction of the arc
    return b.x + b.v * tau * np.cos(mid), b.y + b.v * tau * np.sin(mid), th


class Top:
    """A robot's top as `Renderer._draw` reads it: its tag's cells amid BODY cells as far as the top reaches."""

    def __init__(self, bitmap: np.ndarray, cell: float, radius: float) -> None:
        """bitmap: the printed tag [grey levels], cell [m] its cells' edge, radius [m] the top's."""
        self.n, self.cell = bitmap.shape[0], cell
        self.pad = math.ceil(radius / cell) + 2  # [cells] BODY each side of the tag: the top and more
        self.side = self.n + 2 * self.pad
        self.cells = np.pad(bitmap, self.pad, constant_values=BODY).ravel()

    def read(self, lu: np.ndarray, lv: np.ndarray, out: np.ndarray, work: np.ndarray, col: np.ndarray, index: np.ndarray) -> None:
        """out [grey levels]: the top at body-frame points lu (forward), lv (left) [m] on it, the tag's cells found
        as `_square` finds them (BODY off the tag); off the top, any of these. work, col, index: scratch of lu's shape."""
        half = self.n / 2.0
        np.divide(lu, self.cell, out=work)
        work += half
        np.floor(work, out=work)
        np.copyto(col, work, casting="unsafe")
        np.divide(lv, self.cell, out=work)
        np.subtract(half, work, out=work)
        np.floor(work, out=work)
        np.copyto(index, work, casting="unsafe")  # the tag's row, then the cell's index in `cells`
        index *= self.side
        index += col
        index += self.pad * self.side + self.pad
        self.cells.take(index, mode="clip", out=out)


class Drawn(NamedTuple):
    """A robot as drawn: where, at what poses, over what."""

    box: tuple[slice, slice]  # the image's rows and columns drawn
    pose: np.ndarray  # (x, y, theta) by instant and row: 3 x instants x rows x 1
    under: np.ndarray  # the box before [grey levels]
    image: np.ndarray  # the box drawn [grey levels]


class Renderer:
    """Draws frames of the field and the robots on it, as the configured camera sees them (one frame at a time:
    a frame's working images are kept and drawn into again)."""

    def __init__(self, cfg: Camera, seed: int, readout: float = 0.0) -> None:
        """`readout` [s]: a rolling shutter's, top row to bottom row (0: a global shutter)."""
        self.cfg, self.readout = cfg, readout
        self.lens, self.mount = Lens.of(cfg), Mount.of(cfg)
        self.rng = np.random.default_rng([seed, RNG_STREAM])
        h, w = cfg.height, cfg.width
        v, u = np.mgrid[0:h, 0:w].astype(np.float64)
        self.rays = pixel_rays(self.lens, self.mount, u, v).astype(np.float32)  # H x W x 3
        self.d_u = np.gradient(self.rays, axis=1)  # ray change per pixel along u
        self.d_v = np.gradient(self.rays, axis=0)
        self.tags: dict[int, np.ndarray] = {}  # tag id -> its printed image [grey levels]
        self.tops: dict[int, Top] = {}  # tag id -> a robot's top with that tag
        self.drawn: dict[int, Drawn] = {}  # tag id -> the robot with that tag as last drawn
        # Sensor noise: a bank drawn once, read from a random offset each frame (a fresh draw costs 4 ms).
        self.noise = self.rng.standard_normal(2 * h * w, dtype=np.float32) * np.float32(cfg.noise)
        self.background = self._floor()
        vx, vy = (u - self.lens.K[0, 2]) / w, (v - self.lens.K[1, 2]) / h
        # The gradient's ramps: one along u (1 x W), one along v (H x 1)
        self.ramp_x, self.ramp_y = vx[:1].astype(np.float32), vy[:, :1].astype(np.float32)
        self.vignette = (1.0 - 0.5 * cfg.lighting * (vx**2 + vy**2) * 4.0).astype(np.float32)
        # A frame's working images, drawn into again each frame
        self.canvas, self.gain, self.lit, self.work = self.background.copy(), *(np.empty((h, w), np.float32) for _ in range(3))

    def _bitmap(self, tag: int) -> np.ndarray:
        if tag not in self.tags:
            self.tags[tag] = BLACK + (WHITE - BLACK) * tag_bitmap(tag)
        return self.tags[tag]

    def _top(self, tag: int) -> Top:
        if tag not in self.tops:
            self.tops[tag] = Top(self._bitmap(tag), self.cfg.tag_size / TAG_CELLS, self.cfg.robot_radius)
        return self.tops[tag]

    def _floor(self) -> np.ndarray:
        """The floor with its grid and the fixed tags, under the nominal light (2 x 2 samples a pixel)."""
        total = np.zeros(self.rays.shape[:2], np.float64)
        cell = self.cfg.anchor_size / TAG_CELLS
        for du in (-0.25, 0.25):
            for dv in (-0.25, 0.25):
                x, y = plane_hits(self.mount, self.rays + du * self.d_u + dv * self.d_v, 0.0)
                on_line = (np.abs((x + GRID / 2) % GRID - GRID / 2) < GRID_WIDTH / 2) | (
                    np.abs((y + GRID / 2) % GRID - GRID / 2) < GRID_WIDTH / 2
                )
                img = np.where(on_line, FLOOR - 40.0, FLOOR + 8.0 * np.sin(x * 37.0) * np.sin(y * 29.0))
                for a in self.cfg.anchors:
                    inside, value = _square(self._bitmap(a.id), x - a.x, y - a.y, cell)
                    img = np.where(inside, value, img)
                total += img
        return (total / 4.0).astype(np.float32)

    def _light_terms(self, t: float) -> tuple[float, np.ndarray, np.ndarray]:
        """(swing, gradient along a row (1 x W), gradient down a column (H x 1)) of the light at time t [s]: its gain
        is swing x vignette x (along + down)."""
        a = self.cfg.lighting
        g = 1.0 + a * (0.6 * math.sin(2 * math.pi * t / 7.3) + 0.4 * math.sin(2 * math.pi * t / 2.9 + 1.0))
        gx, gy = a * math.sin(2 * math.pi * t / 11.0), a * math.cos(2 * math.pi * t / 13.0)
        return g, 1.0 + gx * self.ramp_x, gy * self.ramp_y

    def light(self, t: float) -> np.ndarray:
        """The light's gain over the image at time t [s]: a slow swing, a moving gradient, vignetting."""
        g, along, down = self._light_terms(t)
        return cast(np.ndarray, g * self.vignette * (along + down))

    def render(self, t: float, bodies: Sequence[Body]) -> np.ndarray:
        """The frame whose exposure is centred on t [s] (H x W, uint8 grey levels)."""
        # The robots are drawn on the canvas, the background between frames; the floor is lit from the background
        # and the robots' boxes from the canvas, which is then the background again.
        canvas, boxes = self.canvas, []
        try:
            for b in bodies:
                if (box := self._draw(canvas, b)) is not None:
                    boxes.append(box)
            return self._expose(t, boxes)
        finally:
            for box in boxes:
                canvas[box] = self.background[box]

    def _expose(self, t: float, boxes: Sequence[tuple[slice, slice]]) -> np.ndarray:
        """The frame at time t [s] of the canvas drawn in `boxes` (the background elsewhere): lit, noised, clipped
        and truncated to grey levels (the cast astype makes, once the value is in range), a band of rows at a time."""
        g, along, down = self._light_terms(t)
        h, w = self.canvas.shape
        noise = None
        if self.cfg.noise > 0.0:
            start = int(self.rng.integers(0, self.noise.size - h * w))
            noise = self.noise[start : start + h * w].reshape(h, w)
        frame = np.empty((h, w), np.uint8)
        for top in range(0, h, BAND):
            rows = slice(top, top + BAND)
            gain = np.multiply(self.vignette[rows], g, out=self.gain[rows])
            gain *= np.add(along, down[rows], out=self.work[rows])
            img = np.multiply(self.background[rows], gain, out=self.lit[rows])
            for box_rows, cols in boxes:
                on = slice(max(box_rows.start, top), min(box_rows.stop, top + BAND))
                if on.start < on.stop:
                    np.multiply(self.canvas[on, cols], self.gain[on, cols], out=self.lit[on, cols])
            if noise is not None:
                img += noise[rows]
            np.clip(img, 0.0, 255.0, out=frame[rows], casting="unsafe")
        return frame

    def instants(self, b: Body) -> list[float]:
        """[s] the instants of the exposure, from its middle, a body is drawn at (more the faster it moves)."""
        cfg, e = self.cfg, self.cfg.exposure
        travel = (abs(b.v) + abs(b.omega) * cfg.robot_radius) * e  # [m] over the exposure
        px = travel * cfg.fx / max(cfg.z - cfg.tag_height, 1e-3)
        n = min(MAX_BLUR_STEPS, max(1, math.ceil(px / 0.5)))
        return [((k + 0.5) / n - 0.5) * e if n > 1 else 0.0 for k in range(n)]

    def poses(self, b: Body) -> list[tuple[float, float, float]]:
        """(x, y, theta) of a body at the instants of the exposure it is drawn at (constant twist)."""
        return [tuple(float(a) for a in pose_at(b, tau)) for tau in self.instants(b)]  # type: ignore[misc]

    def _sample(self, top: Top, box: tuple[slice, slice], pose: np.ndarray, under: np.ndarray) -> np.ndarray:
        """The box of the image a robot's top is drawn in, at its poses (x, y, theta) by instant and row, over
        `under`: each pixel the mean of 3 x 3 samples at every instant."""
        cfg, r = self.cfg, self.cfg.robot_radius
        rays, d_u, d_v = (a[box] for a in (self.rays, self.d_u, self.d_v))
        # Full size and in float64: each sample's sums below are then plain array operations, to the bit those of
        # the float32 factors broadcast in them
        shape = (len(pose[0]), *under.shape)
        px_, py_, c, s = (np.broadcast_to(a, shape).astype(np.float64) for a in (*pose[:2], np.cos(pose[2]), np.sin(pose[2])))
        minus_s = -s
        fx, fy, lu, lv, work = (np.empty(shape) for _ in range(5))
        col, index = np.empty(shape, np.intp), np.empty(shape, np.intp)
        off_top, seen = np.empty(shape, bool), np.empty(shape, np.float32)
        acc = np.zeros(under.shape, np.float32)
        for du in SUB:  # one sub-sample of every pixel at every instant at a time: a working set the cache holds
            for dv in SUB:
                x, y = plane_hits(self.mount, rays + du * d_u + dv * d_v, cfg.tag_height)
                np.subtract(x, px_, out=fx)
                np.subtract(y, py_, out=fy)
                np.multiply(c, fx, out=lu)  # body frame: u forward, v left
                lu += np.multiply(s, fy, out=work)
                np.multiply(minus_s, fx, out=lv)
                lv += np.multiply(c, fy, out=work)
                np.multiply(lu, lu, out=fx)
                fx += np.multiply(lv, lv, out=fy)
                np.greater(fx, r * r, out=off_top)
                top.read(lu, lv, seen, work, col, index)
                np.copyto(seen, under, where=off_top)
                for one in seen:  # summed in the order of the instants
                    acc += one
        return cast(np.ndarray, acc / (len(SUB) ** 2 * shape[0]))

    def _draw(self, img: np.ndarray, b: Body) -> tuple[slice, slice] | None:
        """Draw one robot's top (a disc) and its tag over the floor, blurred by its motion; the rows and columns
        drawn (None: the robot is out of the frame)."""
        cfg, rs = self.cfg, self.readout
        instants = self.instants(b)
        r = cfg.robot_radius
        ends = [pose_at(b, tau + d) for tau in instants for d in ((-rs / 2, rs / 2) if rs else (0.0,))]
        corners = np.array([(x + dx, y + dy, cfg.tag_height) for x, y, _ in ends for dx in (-r, r) for dy in (-r, r)])
        px = project(self.lens, self.mount, corners)
        h, w = img.shape
        u0, v0 = np.floor(px.min(axis=0)).astype(int) - 2
        u1, v1 = np.ceil(px.max(axis=0)).astype(int) + 3
        u0, v0, u1, v1 = max(u0, 0), max(v0, 0), min(u1, w), min(v1, h)
        if u0 >= u1 or v0 >= v1:
            return None
        box = slice(v0, v1), slice(u0, u1)
        under = img[box]
        rows = row_time(np.arange(v0, v1, dtype=np.float32)[:, None], h, rs)  # [s] (rows x 1)
        # (x, y, theta) at each instant and row (rolling shutter: each row at its own time), instants x rows x 1
        pose = np.stack(np.broadcast_arrays(*pose_at(b, np.array(instants, np.float32)[:, None, None] + rows)))
        last = self.drawn.get(b.tag)
        if last is None or last.box != box or not np.array_equal(last.pose, pose) or not np.array_equal(last.under, under):
            # Nothing else changes what is drawn: a robot standing still is drawn once
            last = self.drawn[b.tag] = Drawn(box, pose, under.copy(), self._sample(self._top(b.tag), box, pose, under))
        under[...] = last.image
        return box
