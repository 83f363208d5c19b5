"""Detected tags to robot fixes: which robot, where, which way, how sure.

Pure. A robot's tag maps through the plane homography at the tag's height; its centre
is the mean of its four corners there and its heading the direction of its top
edge and bottom edge (the tag's right is the robot's forward). The covariance comes
from the geometry: a corner's pixel error (grown when the decoding margin is low, as
with blur), the metres per pixel at that spot of the image, the tag's size in pixels,
and the calibration's residual.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from zenav.services.vps.calibration import Calibration
from zenav.services.vps.detect import Tag

MARGIN_REF = 50.0  # decoding margin of a sharp tag; below it the corner error grows as MARGIN_REF / margin
SIZE_TOLERANCE = 0.25  # a tag whose size on its plane is off by more than this fraction is refused


@dataclass(frozen=True)
class Sighting:
    """One robot located in one frame."""

    robot: str
    tag: int
    x: float  # [m] map frame
    y: float  # [m]
    theta: float  # [rad]
    cov: tuple[float, ...]  # 3x3 row-major: x, y [m^2], theta [rad^2]
    side_px: float  # [px] mean edge of the tag in the image
    row: float = 0.0  # [px] the tag's centre's image row (a rolling shutter exposed it then)


@dataclass
class Located:
    """What one frame gave: a fix per robot seen, and what was refused."""

    fixes: list[Sighting] = field(default_factory=list)
    unknown: int = 0  # tags neither a robot's nor fixed
    duplicates: int = 0  # robot tags seen more than once (all of them refused)
    wrong_size: int = 0  # robot tags whose size on their plane is not the configured one


def _heading(c: np.ndarray) -> float:
    """Heading [rad] of a tag from its corners on its plane (TL, TR, BR, BL)."""
    fwd = (c[1] - c[0]) + (c[2] - c[3])
    left = (c[0] - c[3]) + (c[1] - c[2])
    v = fwd + np.array([left[1], -left[0]])  # left turned a quarter clockwise points forward too
    return math.atan2(v[1], v[0])


def sighting(cal: Calibration, tag: Tag, robot: str, h: float, corner_sigma: float) -> tuple[Sighting, float]:
    """A robot's fix from its tag at height h [m] (corner_sigma [px]), and the tag's edge [m] on that plane."""
    on_plane = cal.to_plane(tag.corners, h)
    centre = on_plane.mean(axis=0)
    edges = np.roll(on_plane, -1, axis=0) - on_plane
    edge_m = float(np.mean(np.linalg.norm(edges, axis=1)))
    c_px = tag.corners.mean(axis=0)
    side_px = float(np.mean(np.linalg.norm(np.roll(tag.corners, -1, axis=0) - tag.corners, axis=1)))
    probe = cal.to_plane(np.array([c_px + (0.5, 0.0), c_px - (0.5, 0.0), c_px + (0.0, 0.5), c_px - (0.0, 0.5)]), h)
    J = np.column_stack([probe[0] - probe[1], probe[2] - probe[3]])  # [m/px] at the tag
    s = corner_sigma * (max(1.0, MARGIN_REF / tag.margin) if tag.margin > 0 else 1.0)
    cov_xy = J @ J.T * (s * s / 4.0) + np.eye(2) * cal.rms**2
    var_th = (s / side_px) ** 2
    cov = (cov_xy[0, 0], cov_xy[0, 1], 0.0, cov_xy[1, 0], cov_xy[1, 1], 0.0, 0.0, 0.0, var_th)
    fix = Sighting(
        robot, tag.id, float(centre[0]), float(centre[1]), _heading(on_plane), tuple(float(v) for v in cov), side_px, float(c_px[1])
    )
    return fix, edge_m


def locate(
    tags: list[Tag],
    cal: Calibration,
    robots: Mapping[str, int],  # robot id -> tag id
    anchors: set[int],  # ids of the fixed tags
    tag_size: float,  # [m]
    tag_height: float,  # [m]
    corner_sigma: float,  # [px]
) -> Located:
    """The fixes of the robots whose tags are in `tags`, once each."""
    owner = {tag: robot for robot, tag in robots.items()}
    counts: dict[int, int] = {}
    for t in tags:
        counts[t.id] = counts.get(t.id, 0) + 1
    out = Located()
    for t in tags:
        if t.id in anchors:
            continue
        if t.id not in owner:
            out.unknown += 1
        elif counts[t.id] > 1:
            out.duplicates += 1
        else:
            fix, edge_m = sighting(cal, t, owner[t.id], tag_height, corner_sigma)
            if abs(edge_m / tag_size - 1.0) > SIZE_TOLERANCE:
                out.wrong_size += 1
            else:
                out.fixes.append(fix)
    return out
