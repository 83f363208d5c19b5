"""The overhead camera measured: render and detection time, fix accuracy, two robots.

`zenav bench camera` measures each camera of CAMERAS with the detector the vps would pick,
and the whole stack with the camera VPS against the synthetic one.

Frames are rendered by the sim's camera model from known poses, with a real camera's
errors ([camera] model = "realistic": the lens off its calibration, a tilted and shaken
mount, tag height and print scale, rolling shutter, JPEG) but for the ideal row; the VPS pipeline
(detect, undistort, plane homography from a calibration fitted to the fixed tags in
a frame without robots) turns them into fixes, compared with the truth. Accuracy runs
over a grid of poses across the camera's view, at rest and moving (0.3 m/s and
1 rad/s: motion blur), at the default camera and at a worse one. `z` is each fix's
error over the sigma its covariance claims (about 1 when the covariance is honest).
"""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import msgspec
import numpy as np

from zenav.common import codec
from zenav.common import messages as m
from zenav.common.config import Camera
from zenav.common.geometry import wrap_angle
from zenav.services.vps import calibration, detect, locate, placing
from zenav.services.vps import frames as camera_frames
from zenav.world.camera import tag_pixels
from zenav.world.camera_errors import imperfect, jpeg, shake
from zenav.world.render import Body, Renderer, pose_at

# A worse camera: half the resolution, darker (longer exposure, more blur), noisier, more uneven light.
WORSE = {"width": 320, "height": 240, "fx": 266.5, "fy": 266.5, "exposure": 0.03, "noise": 6.0, "lighting": 0.4, "k1": -0.12}
CAMERAS = {
    "default 640x480": Camera(),  # a real camera's errors ([camera] model = "realistic")
    "ideal 640x480": Camera(model="ideal"),  # the same without them: what the image alone allows
    "worse 320x240, blur, noise, distortion": msgspec.structs.replace(Camera(), **WORSE),
}
SHAKE_STREAM = 0x534841  # the mount's shake, as the sim's camera draws it
XS, YS = np.linspace(-0.4, 1.4, 7).tolist(), np.linspace(0.0, 1.0, 5).tolist()  # [m] the pose grid, inside the default view
HEADINGS = (0.3, 1.9, -2.6, -1.0)  # [rad]
MOTIONS = ((0.0, 0.0), (0.3, 1.0))  # (v [m/s], omega [rad/s])


def pct(values: Sequence[float], q: float) -> float:
    """The q-th percentile (nan when empty)."""
    return float(np.percentile(values, q)) if len(values) else math.nan


@dataclass(frozen=True)
class Accuracy:
    """Fixes against the truth over a set of poses."""

    frames: int
    found: int  # frames whose robot gave a fix
    pos_mm: tuple[float, float]  # p50, p95 of the position error [mm]
    head_deg: tuple[float, float]  # p50, p95 of the heading error [deg]
    z: tuple[float, float]  # p50 of position error / claimed sigma, heading likewise

    def row(self, name: str) -> str:
        return (
            f"| {name} | {self.found}/{self.frames} | {self.pos_mm[0]:.2f} / {self.pos_mm[1]:.2f} | "
            f"{self.head_deg[0]:.2f} / {self.head_deg[1]:.2f} | {self.z[0]:.2f} / {self.z[1]:.2f} |"
        )


class Pipeline:
    """The sim's camera (its errors drawn for the seed: world/camera_errors.py) and the VPS's detector with a
    calibration from the fixed tags."""

    def __init__(self, cfg: Camera, backend: detect.Backend = "auto", seed: int = 1) -> None:
        self.cfg, self.errors = cfg, imperfect(cfg, seed)
        self.renderer = Renderer(self.errors.true, seed, readout=self.errors.readout)
        self.rng = np.random.default_rng([seed, SHAKE_STREAM])
        self.detector = detect.make(backend, tag_pixels(cfg))
        tags = self.detector.detect(self.shoot(0.0, []))
        self.cal = calibration.calibrate(tags, cfg)

    def shoot(self, t: float, bodies: Sequence[Body]) -> np.ndarray:
        """A frame as the vps gets it: rendered, shaken, through JPEG when the camera sends JPEG."""
        img = shake(self.renderer.render(t, bodies), self.errors, self.rng)
        q = self.errors.jpeg_quality
        if q <= 0:
            return img
        out = cv2.imdecode(np.frombuffer(jpeg(img, q), np.uint8), cv2.IMREAD_GRAYSCALE)
        assert out is not None  # a JPEG just encoded
        return np.asarray(out)

    def locate(self, img: np.ndarray, robots: dict[str, int]) -> locate.Located:
        c = self.cfg
        return locate.locate(
            self.detector.detect(img), self.cal, robots, {a.id for a in c.anchors}, c.tag_size, c.tag_height, c.corner_sigma
        )


def accuracy(p: Pipeline, xs: Sequence[float] = XS, ys: Sequence[float] = YS, motions: Sequence[tuple[float, float]] = MOTIONS) -> Accuracy:
    """Errors of one robot's fixes over a grid of poses: every (x, y) [m] at every heading and motion, each fix
    against the truth at the time the vps stamps it (its row's, with a rolling shutter)."""
    pos, head, zp, zh, n = [], [], [], [], 0
    for k, ((x, y), th, (v, w)) in enumerate(itertools.product(itertools.product(xs, ys), HEADINGS, motions)):
        n += 1
        body = Body(0, float(x), float(y), th, v, w)
        fixes = p.locate(p.shoot(0.1 * k, [body]), {"r1": 0}).fixes
        if not fixes:
            continue
        f = fixes[0]
        tx, ty, tth = pose_at(body, placing.stamp(0.0, f, p.cfg))
        cov = placing.widen(f, p.cfg)
        e, eh = math.hypot(f.x - tx, f.y - ty), abs(wrap_angle(f.theta - tth))
        pos.append(e * 1000.0)
        head.append(math.degrees(eh))
        zp.append(e / math.sqrt(cov[0] + cov[4]))
        zh.append(eh / math.sqrt(cov[8]))
    return Accuracy(n, len(pos), (pct(pos, 50), pct(pos, 95)), (pct(head, 50), pct(head, 95)), (pct(zp, 50), pct(zh, 50)))


@dataclass(frozen=True)
class Timing:
    """Milliseconds per frame: p50 and p99 of the wall time, p50 of the CPU time."""

    wall: tuple[float, float]
    cpu: float

    def cell(self) -> str:
        return f"{self.wall[0]:.1f} / {self.wall[1]:.1f} ({self.cpu:.1f})"


STAGES = ("render", "wire", "detect")


def timing(p: Pipeline, frames: int) -> dict[str, Timing]:
    """Per stage, for frames with two robots moving: render (sim), wire (CameraFrame encoded and
    decoded, as a message and as pixels), detect (the VPS: tags found and located)."""
    wall: dict[str, list[float]] = {k: [] for k in STAGES}
    cpu: dict[str, list[float]] = {k: [] for k in STAGES}
    for k in range(frames):
        t = 0.1 * k
        bodies = [Body(0, 0.5 + 0.6 * math.cos(t), 0.5 + 0.4 * math.sin(t), t, 0.3, 1.0), Body(1, 0.5, 0.5, -t, 0.0, -1.0)]
        marks = [(time.perf_counter(), time.thread_time())]
        img = p.shoot(t, bodies)
        marks.append((time.perf_counter(), time.thread_time()))
        msg = codec.decode(codec.encode(camera_frames.encode(img, t, k)), m.CameraFrame)
        img = camera_frames.decode(msg, p.cfg.width, p.cfg.height)
        marks.append((time.perf_counter(), time.thread_time()))
        p.locate(img, {"r1": 0, "r2": 1})
        marks.append((time.perf_counter(), time.thread_time()))
        for stage, (w0, c0), (w1, c1) in zip(STAGES, marks, marks[1:]):
            wall[stage].append((w1 - w0) * 1e3)
            cpu[stage].append((c1 - c0) * 1e3)
    return {k: Timing((pct(wall[k], 50), pct(wall[k], 99)), pct(cpu[k], 50)) for k in STAGES}


def two_robots(p: Pipeline, trials: int, seed: int = 7) -> tuple[int, int, int]:
    """(frames, frames with both robots fixed, fixes given to the wrong robot) over random pairs of poses."""
    rng = np.random.default_rng(seed)
    both = wrong = 0
    for k in range(trials):
        a = (rng.uniform(-0.4, 0.4), rng.uniform(0.0, 1.0), rng.uniform(-math.pi, math.pi))
        b = (rng.uniform(0.6, 1.4), rng.uniform(0.0, 1.0), rng.uniform(-math.pi, math.pi))
        img = p.shoot(0.1 * k, [Body(0, *a), Body(1, *b)])
        fixes = {f.robot: f for f in p.locate(img, {"r1": 0, "r2": 1}).fixes}
        both += len(fixes) == 2
        truth = {"r1": a, "r2": b}
        wrong += sum(math.hypot(f.x - truth[r][0], f.y - truth[r][1]) > 0.05 for r, f in fixes.items())
    return trials, both, wrong


@dataclass(frozen=True)
class Measured:
    """One camera measured: time per stage, fix accuracy, two robots told apart, the calibration's residual."""

    timing: dict[str, Timing]
    accuracy: Accuracy
    pairs: tuple[int, int, int]  # (frames, both fixed, fixes given to the wrong robot)
    cal_rms: float  # [m]


def measure(cfg: Camera, frames: int, backend: detect.Backend = "auto", pairs: int = 50) -> Measured:
    """Everything this module measures, for one camera and detector."""
    p = Pipeline(cfg, backend)
    return Measured(timing(p, frames), accuracy(p), two_robots(p, pairs), p.cal.rms)


def lines(measured: dict[str, Measured], frames: int) -> list[str]:
    """The measurements as markdown: time per frame, accuracy, two robots."""
    out = [
        f"Milliseconds per frame over {frames} frames with two robots moving, p50 / p99 of the wall time (p50 of the "
        "CPU time; other load on the host shows in the wall):",
        "",
        "| camera, detector | render (sim) | frame encode + decode | detect + locate (vps) | calibration rms [mm] |",
        "|---|---|---|---|---|",
        *(f"| {name} | {' | '.join(r.timing[k].cell() for k in STAGES)} | {r.cal_rms * 1000:.2f} |" for name, r in measured.items()),
        "",
        f"Fix accuracy over {len(XS) * len(YS)} positions x {len(HEADINGS)} headings, at rest and at (0.3 m/s, 1 rad/s):",
        "",
        "| camera, detector | fixes | position err p50 / p95 [mm] | heading err p50 / p95 [deg] | z pos / z heading p50 |",
        "|---|---|---|---|---|",
        *(r.accuracy.row(name) for name, r in measured.items()),
        "",
    ]
    for name, r in measured.items():
        n, both, wrong = r.pairs
        out.append(f"- two robots, {name}: both fixed in {both}/{n} frames, fixes given to the wrong robot: {wrong}")
    return out
