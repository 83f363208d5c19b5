"""A 1280x720 camera read by the VPS: the windowed search against the whole-frame one, on the same frames.

The sim's camera model renders a 1280x720 camera over the default field (the default
camera's view, its focal length scaled to the taller frame) with two robots moving; each
frame goes through the wire (encoded and decoded as a CameraFrame) to two VPS readers
with the same detector and calibration: one that looks for each robot's tag in a window
round its predicted place (services/vps/track.py), one that searches every frame whole.
Per frame of the windowed reader: CPU time (this thread's, its periodic whole search
included) and wall time from the frame's message to its fixes (frame to fix; the
periodic whole search comes after them, as the vps service runs it). Then the fixes compared: any a whole search
gave that the windowed one did not is a lost fix.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass

import msgspec
import numpy as np

from zenav.common import codec
from zenav.common import messages as m
from zenav.common.config import Camera
from zenav.services.vps import calibration, detect
from zenav.services.vps import frames as camera_frames
from zenav.services.vps.reader import Reader
from zenav.world.camera import tag_pixels
from zenav.world.render import Body, Renderer

SIZE = (1280, 720)
ROBOTS = {"r1": 0, "r2": 1}
FRAME_PERIOD = 0.1  # [s] 10 Hz


def camera_720p(base: Camera | None = None) -> Camera:
    """The default camera at 1280x720: its vertical view kept (focal length scaled by 720 / 480), wider across."""
    base = base or Camera()
    k = SIZE[1] / base.height
    return msgspec.structs.replace(base, width=SIZE[0], height=SIZE[1], fx=base.fx * k, fy=base.fy * k, robots=ROBOTS)


def bodies(t: float) -> list[Body]:
    """Two robots moving at t [s]: one round an ellipse (0.3 m/s and more), one turning on the spot."""
    return [Body(0, 0.5 + 0.6 * math.cos(t), 0.5 + 0.4 * math.sin(t), t, 0.3, 1.0), Body(1, 0.5, 0.5, -t, 0.0, -1.0)]


def messages(cfg: Camera, frames: int, seed: int = 1) -> list[m.CameraFrame]:
    """`frames` frames at 10 Hz, each as the VPS receives it (encoded and decoded on the wire)."""
    renderer = Renderer(cfg, seed)
    out = []
    for k in range(frames):
        t = FRAME_PERIOD * (k + 1)
        frame = camera_frames.encode(renderer.render(t, bodies(t)), t, k)
        out.append(codec.decode(codec.encode(frame), m.CameraFrame))
    return out


@dataclass(frozen=True)
class Compared:
    """The windowed reader against the whole-frame one on the same frames."""

    frames: int
    cpu_ms: float  # [ms] mean CPU a frame, windowed
    full_cpu_ms: float  # [ms] mean CPU a frame, whole-frame search
    to_fix: tuple[float, float]  # [ms] frame to fix, windowed, p50 and p95 (wall)
    whole: int  # frames the windowed reader searched whole
    fixes: int  # fixes the whole-frame search gave
    lost: int  # of those, fixes the windowed reader did not give
    moved_mm: float  # [mm] the largest difference between the two readers' fixes of a frame

    @property
    def per_core(self) -> float:
        """[frames/s per core] windowed."""
        return 1e3 / self.cpu_ms

    def line(self) -> str:
        return (
            f"{SIZE[0]}x{SIZE[1]}: {self.per_core:.0f} frames/s per core ({self.cpu_ms:.2f} ms of CPU a frame, the "
            f"whole-frame search {self.full_cpu_ms:.2f}: {1e3 / self.full_cpu_ms:.0f}/s); frame to fix p50 {self.to_fix[0]:.2f} ms, "
            f"p95 {self.to_fix[1]:.2f} ms; {self.whole} of {self.frames} frames searched whole; fixes lost against the "
            f"whole-frame search: {self.lost} of {self.fixes} (largest difference {self.moved_mm:.3f} mm)"
        )


def readers(cfg: Camera, backend: detect.Backend = "auto") -> tuple[Reader, Reader]:
    """(windowed, whole-frame) readers sharing one calibration, fitted to a frame without robots."""
    det = detect.make(backend, tag_pixels(cfg))
    cal = calibration.calibrate(det.detect(Renderer(cfg, 1).render(0.0, [])), cfg)
    return Reader(cfg, cal, det), Reader(cfg, cal, det, windowed=False)


def _timed(reader: Reader, frame: m.CameraFrame) -> tuple[dict[str, m.VpsPose], float, float]:
    """(fixes, CPU [ms] with the whole search after them, wall [ms] frame to fix)."""
    w0, c0 = time.perf_counter(), time.thread_time()
    fixes = dict(reader.read(frame).fixes)
    wall = (time.perf_counter() - w0) * 1e3
    reader.explore()
    return fixes, (time.thread_time() - c0) * 1e3, wall


def compare(cfg: Camera, msgs: Sequence[m.CameraFrame], backend: detect.Backend = "auto") -> Compared:
    """Both readers over the same frames, in turn frame by frame."""
    windowed, full = readers(cfg, backend)
    cpu, full_cpu, wall = [], [], []
    fixes = lost = 0
    moved = 0.0
    for frame in msgs:
        got, c, w = _timed(windowed, frame)
        want, fc, _ = _timed(full, frame)
        cpu.append(c)
        wall.append(w)
        full_cpu.append(fc)
        fixes += len(want)
        lost += sum(r not in got for r in want)
        moved = max([moved, *(math.hypot(got[r].x - f.x, got[r].y - f.y) * 1e3 for r, f in want.items() if r in got)])
    p50, p95 = np.percentile(wall, [50, 95])
    return Compared(len(msgs), float(np.mean(cpu)), float(np.mean(full_cpu)), (float(p50), float(p95)), windowed.whole, fixes, lost, moved)


def measure(frames: int, backend: detect.Backend = "auto") -> Compared:
    """The 720p camera's frames rendered, then both readers over them."""
    cfg = camera_720p()
    return compare(cfg, messages(cfg, frames), backend)
