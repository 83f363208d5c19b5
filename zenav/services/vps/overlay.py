"""A frame with what the VPS sees drawn on it: the field grid, the tags, the robots' fixes."""

from __future__ import annotations

import math

import cv2
import numpy as np

from zenav.common.config import Camera
from zenav.services.vps.calibration import Calibration
from zenav.services.vps.detect import Tag
from zenav.services.vps.locate import Located

GRID = 0.5  # [m] spacing of the drawn grid
GREEN, BLUE, RED, YELLOW = (60, 200, 60), (230, 140, 40), (40, 40, 230), (40, 220, 230)  # BGR


def _text(img: np.ndarray, text: str, at: tuple[int, int], colour: tuple[int, int, int], scale: float = 0.4) -> None:
    """Text with a dark outline, kept inside the image."""
    (w, h), _ = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, scale, 1)
    x, y = min(max(at[0], 2), img.shape[1] - w - 2), min(max(at[1], h + 2), img.shape[0] - 2)
    cv2.putText(img, text, (x, y), cv2.FONT_HERSHEY_SIMPLEX, scale, (0, 0, 0), 3, cv2.LINE_AA)
    cv2.putText(img, text, (x, y), cv2.FONT_HERSHEY_SIMPLEX, scale, colour, 1, cv2.LINE_AA)


def _project(cal: Calibration, pts: np.ndarray) -> np.ndarray:
    """Map points (N x 3) [m] -> pixels as seen, through the calibration."""
    R, t = cal.pose()
    rvec, _ = cv2.Rodrigues(R)
    out, _ = cv2.projectPoints(np.asarray(pts, dtype=np.float64).reshape(-1, 1, 3), rvec, t, cal.lens.K, cal.lens.dist)
    return out.reshape(-1, 2)


def _grid(img: np.ndarray, cal: Calibration) -> None:
    """Floor lines every GRID metres over the view (curved as the lens bends them), labelled in metres."""
    h, w = img.shape[:2]
    corners = cal.to_plane(np.array([(0, 0), (w, 0), (w, h), (0, h)], dtype=float), 0.0)
    (x0, y0), (x1, y1) = corners.min(axis=0), corners.max(axis=0)
    xs = np.arange(math.floor(x0 / GRID) * GRID, x1 + GRID, GRID)
    ys = np.arange(math.floor(y0 / GRID) * GRID, y1 + GRID, GRID)
    for x in xs:
        line = _project(cal, np.array([(x, y, 0.0) for y in np.linspace(y0, y1, 60)]))
        cv2.polylines(img, [np.round(line).astype(np.int32)], False, YELLOW, 1, cv2.LINE_AA)
    for y in ys:
        line = _project(cal, np.array([(x, y, 0.0) for x in np.linspace(x0, x1, 80)]))
        cv2.polylines(img, [np.round(line).astype(np.int32)], False, YELLOW, 1, cv2.LINE_AA)
    for x in xs:
        for y in ys:
            if float(x).is_integer() and float(y).is_integer():
                u, v = _project(cal, np.array([(x, y, 0.0)]))[0]
                _text(img, f"({x:.0f},{y:.0f})", (int(u) + 3, int(v) - 3), YELLOW, 0.35)


def draw(grey: np.ndarray, tags: list[Tag], cfg: Camera, cal: Calibration | None, located: Located | None) -> np.ndarray:
    """A BGR picture of a frame: grid (with a calibration), tag outlines (robots green, fixed blue, others red), fixes."""
    img = cv2.cvtColor(grey, cv2.COLOR_GRAY2BGR)
    if cal is not None:
        _grid(img, cal)
    robots = set(cfg.robots.values())
    anchors = {a.id for a in cfg.anchors}
    for tag in tags:
        colour = GREEN if tag.id in robots else BLUE if tag.id in anchors else RED
        cv2.polylines(img, [np.round(tag.corners).astype(np.int32)], True, colour, 1, cv2.LINE_AA)
        cv2.circle(img, tuple(np.round(tag.corners[0]).astype(int)), 2, colour, -1)  # the printed top-left
        u, v = tag.corners.mean(axis=0)
        _text(img, str(tag.id), (int(u) - 6, int(v) + 4), colour)
    if cal is not None and located is not None:
        for f in located.fixes:
            tip = (f.x + 0.15 * math.cos(f.theta), f.y + 0.15 * math.sin(f.theta), cfg.tag_height)  # [m] an arrow 15 cm ahead
            ends = _project(cal, np.array([(f.x, f.y, cfg.tag_height), tip]))
            a, b = (tuple(np.round(p).astype(int)) for p in ends)
            cv2.arrowedLine(img, a, b, GREEN, 2, cv2.LINE_AA, tipLength=0.25)
            text = f"{f.robot} ({f.x:.3f}, {f.y:.3f}) {math.degrees(f.theta):.1f} deg"
            _text(img, text, (a[0] - 60, a[1] + 34), GREEN)
    return img
