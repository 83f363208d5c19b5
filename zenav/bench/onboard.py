"""The onboard camera section: its fixes' error against distance and tag count, and the fused pose driving the square.

    zenav bench studies onboard   # 300 poses, then the square driven 3 laps at rtf 1

Fixes: `poses` random robot poses, at rest, on the default field (its twelve wall tags, FRC's 0.1651 m), each frame
rendered by the sim's onboard camera ([onboard_camera] defaults: 640 x 480, 65 deg, 2 grey levels of noise, and its
realistic errors: the true lens, mount and tags as placed drawn for the seed, the chassis' shake, JPEG), its tags
detected, and the pose solved from all of them, then from each tag alone (the current estimate, for the one-tag
ambiguity, is the truth off by 2 cm and 1 deg). Errors against the truth, by tag count and by distance. A fix
accepted more than 5 cm off the truth and outside its own covariance's 99.9 % ellipse counts as a wrong one (a
wrong ambiguity pick, a bad solve); one far off but saying so (a large covariance) does not.

Drive: the whole stack on a real router driving the 1 m square trial `laps` times, the vps reading the
onboard camera alone (each service its own process, as `zenav up` runs them), then with the overhead camera's vps
beside it (two vps, two latencies; in this process): the fused pose's RMSE against the truth, and the fixes the
localizer accepted and rejected. Simulated.
"""

from __future__ import annotations

import math
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import msgspec
import numpy as np

from zenav.bench import accuracy
from zenav.common.config import Settings
from zenav.common.onboardcam import OnboardCamera
from zenav.services.vps import detect, onboard
from zenav.services.vps.onboard_reader import TAG_PX
from zenav.world.camera_errors import imperfect_onboard, jpeg, shake, tags_as_placed
from zenav.world.onboard import OnboardRenderer

WRONG_M = 0.05  # [m] an accepted fix this far off the truth ...
WRONG_D2 = 13.8  # ... and outside its own covariance's 99.9 % ellipse (Mahalanobis d^2, 2 dof) is a wrong one
ESTIMATE_ERROR = (0.02, math.radians(1.0))  # [m, rad] how far off the estimate given for the ambiguity is
DISTANCES = (0.0, 1.0, 2.0, 3.0, 4.5)  # [m] bin edges
AREA = (-0.7, 2.7)  # [m] x and y of the poses drawn (the field is -1..3, its walls at the edges)


@dataclass
class Bin:
    """Fixes of one kind: position [m] and heading [rad] errors, and what was refused."""

    pos: list[float] = field(default_factory=list)
    heading: list[float] = field(default_factory=list)
    refused: dict[str, int] = field(default_factory=dict)
    wrong: int = 0

    def add(self, got: onboard.TagFix | onboard.Refused | None, truth: Sequence[float]) -> None:
        if isinstance(got, onboard.Refused):
            self.refused[got.reason] = self.refused.get(got.reason, 0) + 1
        elif got is not None:
            e, eh = math.hypot(got.x - truth[0], got.y - truth[1]), abs(math.remainder(got.theta - truth[2], math.tau))
            self.pos.append(e)
            self.heading.append(eh)
            d = np.array([got.x - truth[0], got.y - truth[1]])
            cov = np.array(got.cov).reshape(3, 3)[:2, :2]
            self.wrong += e > WRONG_M and float(d @ np.linalg.solve(cov, d)) > WRONG_D2

    def row(self, label: str) -> str:
        if not self.pos:
            return f"| {label} | 0 | | | | {self._refused()} | {self.wrong} |"
        p = np.array(self.pos) * 100.0
        h = np.degrees(self.heading)
        return (
            f"| {label} | {len(p)} | {np.median(p):.2f} / {np.percentile(p, 95):.2f} | {np.sqrt(np.mean(p**2)):.2f} |"
            f" {np.median(h):.2f} / {np.percentile(h, 95):.2f} | {self._refused()} | {self.wrong} |"
        )

    def _refused(self) -> str:
        return ", ".join(f"{k} {v}" for k, v in sorted(self.refused.items())) or "0"


def fix_errors(poses: int, seed: int) -> list[str]:
    """The fix error table: by the number of tags solved over, and one tag alone by distance."""
    settings = Settings.load(None)
    cfg = OnboardCamera()
    tags, shapes = settings.field.tags, settings.field.shapes()
    layout = {t.id: t for t in tags}
    errors = imperfect_onboard(cfg, seed)
    renderer = OnboardRenderer(errors.true, tags_as_placed(cfg, tags, seed), shapes, seed)

    def shoot(truth: tuple[float, float, float]) -> np.ndarray:
        img = shake(renderer.render(*truth), errors, rng)
        if errors.jpeg_quality <= 0:
            return img
        return np.asarray(cv2.imdecode(np.frombuffer(jpeg(img, errors.jpeg_quality), np.uint8), cv2.IMREAD_GRAYSCALE))

    detector = detect.make("auto", TAG_PX)
    rng = np.random.default_rng(seed)
    by_count: dict[str, Bin] = {k: Bin() for k in ("1 tag", "2 tags", "3+ tags")}
    by_distance = [Bin() for _ in DISTANCES[:-1]]
    frames_without = 0
    for _ in range(poses):
        truth = (float(rng.uniform(*AREA)), float(rng.uniform(*AREA)), float(rng.uniform(-math.pi, math.pi)))
        off = rng.normal(0.0, 1.0, 3) * (*[ESTIMATE_ERROR[0]] * 2, ESTIMATE_ERROR[1])
        estimate = (truth[0] + float(off[0]), truth[1] + float(off[1]), truth[2] + float(off[2]))
        found = [t for t in detector.detect(shoot(truth)) if t.id in layout]
        if not found:
            frames_without += 1
            continue
        key = "1 tag" if len(found) == 1 else "2 tags" if len(found) == 2 else "3+ tags"
        by_count[key].add(onboard.solve(found, layout, cfg, estimate), truth)
        for t in found:  # each tag alone, as a frame that showed only it
            got = onboard.solve([t], layout, msgspec.structs.replace(cfg, max_distance=100.0), estimate)
            d = float(np.linalg.norm(np.array([layout[t.id].x - truth[0], layout[t.id].y - truth[1]])))
            i = int(np.searchsorted(DISTANCES, d, side="right")) - 1
            if 0 <= i < len(by_distance):
                by_distance[i].add(got, truth)
    head = "| fixes | n | position error median / p95 [cm] | position RMSE [cm] | heading error median / p95 [deg] | refused | wrong |"
    rule = "|---|---|---|---|---|---|---|"
    out = [f"{poses} poses, {frames_without} with no tag in sight.", "", "All the tags in the frame:", "", head, rule]
    out += [b.row(k) for k, b in by_count.items()]
    out += ["", "Each tag alone (no max_distance), by the robot's distance to it:", "", head, rule]
    out += [b.row(f"{lo:g}-{hi:g} m") for b, lo, hi in zip(by_distance, DISTANCES[:-1], DISTANCES[1:])]
    return out


def drive(laps: float, rtf: float) -> list[str]:
    """The fused pose's RMSE driving the square, onboard camera alone and beside the overhead camera."""
    out = [
        "| cameras | harness | position RMSE [cm] | max [cm] | heading RMSE [deg] | fixes accepted / rejected | goals failed |",
        "|---|---|---|---|---|---|---|",
    ]
    # The onboard camera alone as `zenav up` runs it (each service its own process); both cameras in this process
    # (the second camera's vps beside the stack's).
    for vps, harness in (("onboard", "processes"), ("camera+onboard", "in-process")):
        spec = accuracy.Spec(vps=vps, laps=laps, harness=harness)
        with tempfile.TemporaryDirectory() as logs:
            r = accuracy.run(spec, rtf, Path(logs))
        s = r.pose
        fixes = r.trial.rec.msgs.get("localizer/fixes", [])
        used = sum(1 for f in fixes if f.accepted)
        out.append(
            f"| {vps} | {harness} | {s.rmse * 100:.2f} | {s.max * 100:.2f} | {math.degrees(s.heading_rmse):.2f} |"
            f" {used} / {len(fixes) - used} | {len(r.failures)} |"
        )
    return out
