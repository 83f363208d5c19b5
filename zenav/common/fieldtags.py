"""The field's fixed tags in 3D: WPILib's AprilTagFieldLayout JSON read as tags, and each tag's frame and corners.

Pure: no I/O. A tag's frame follows WPILib's: +x out of its printed face, +z up the tag when it hangs upright,
+y to the right of a viewer facing it; its rotation is yaw about map z, then pitch about y, then roll about x.
Corners are in the printed tag's order as a viewer facing it reads it (detect.Tag's): top-left, top-right,
bottom-right, bottom-left, each at half the black square's edge from the centre.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, cast

import numpy as np


class LayoutError(ValueError):
    """A tag layout file that is not a WPILib AprilTagFieldLayout (what is wrong, where)."""


def rotation(yaw: float, pitch: float = 0.0, roll: float = 0.0) -> np.ndarray:
    """3x3 tag-to-map rotation: Rz(yaw) @ Ry(pitch) @ Rx(roll) [rad]."""
    cy, sy, cp, sp, cr, sr = math.cos(yaw), math.sin(yaw), math.cos(pitch), math.sin(pitch), math.cos(roll), math.sin(roll)
    rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
    return cast(np.ndarray, rz @ ry @ rx)


def euler(w: float, x: float, y: float, z: float) -> tuple[float, float, float]:
    """(yaw, pitch, roll) [rad] of a quaternion (W, X, Y, Z), the inverse of geometry.quaternion; LayoutError when it is zero."""
    n = math.sqrt(w * w + x * x + y * y + z * z)
    if not math.isfinite(n) or n < 1e-9:
        raise LayoutError(f"the quaternion (W={w}, X={x}, Y={y}, Z={z}) is not a rotation")
    w, x, y, z = w / n, x / n, y / n, z / n
    yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    pitch = math.asin(max(-1.0, min(1.0, 2.0 * (w * y - z * x))))
    roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    return yaw, pitch, roll


TAG_SHAPE = "a tag is {ID, pose: {translation: {x, y, z}, rotation: {quaternion: {W, X, Y, Z}}}}"
LOCAL_CORNERS = np.array([[0.0, -1.0, 1.0], [0.0, 1.0, 1.0], [0.0, 1.0, -1.0], [0.0, -1.0, -1.0]]) / 2.0  # x size


def corners(size: float, x: float, y: float, z: float, yaw: float, pitch: float = 0.0, roll: float = 0.0) -> np.ndarray:
    """4 x 3 [m] map points of a tag's black square: top-left, top-right, bottom-right, bottom-left as seen facing it."""
    return cast(np.ndarray, np.array([x, y, z]) + (rotation(yaw, pitch, roll) @ (LOCAL_CORNERS * size).T).T)


def wpilib_tags(raw: Any, size: float | None, where: str) -> list[dict[str, float]]:
    """The tags of a WPILib AprilTagFieldLayout (`{"tags": [{"ID", "pose": {"translation", "rotation": {"quaternion"}}}],
    "field": {...}}`) as [field] tags of edge `size` [m] (the layout has none); LayoutError names what is wrong."""
    if not isinstance(raw, Mapping) or not isinstance(raw.get("tags"), list):
        raise LayoutError(f"{where}: a WPILib AprilTagFieldLayout is an object with a `tags` list")
    if size is None:
        raise LayoutError(f"{where}: a WPILib layout gives no tag size: set [field] tag_size (FRC's tags: 0.1651 m)")
    out = []
    for i, tag in enumerate(raw["tags"]):
        try:
            pose = tag["pose"]
            t, q = pose["translation"], pose["rotation"]["quaternion"]
            yaw, pitch, roll = euler(float(q["W"]), float(q["X"]), float(q["Y"]), float(q["Z"]))
            entry = {"id": int(tag["ID"]), "size": size, "x": float(t["x"]), "y": float(t["y"]), "z": float(t["z"])}
        except (KeyError, TypeError, ValueError) as e:
            why = f"missing {e}" if isinstance(e, KeyError) else str(e)
            raise LayoutError(f"{where}: tags[{i}]: {why} ({TAG_SHAPE})") from None
        out.append({**entry, "yaw": yaw, "pitch": pitch, "roll": roll})
    return out


EDGE_TOLERANCE = 0.05  # [m] a tag may stand this far beyond the field's edge (on the wall's face)
FACING_PROBE = 0.1  # [m] a point this far in front of a tag must lie on the field, or the tag faces out of it


def misplaced(
    tag_id: int, x: float, y: float, yaw: float, pitch: float, roll: float, bounds: tuple[float, float, float, float]
) -> str | None:
    """Why a tag at (x, y) facing (yaw, pitch, roll) can be seen from no point of the field (x_min, y_min, x_max,
    y_max), or None: it lies outside it, or it faces out of it (a yaw off by pi)."""
    x0, y0, x1, y1 = bounds
    t = EDGE_TOLERANCE
    if not (x0 - t <= x <= x1 + t and y0 - t <= y <= y1 + t):
        return f"tag {tag_id} at ({x:g}, {y:g}) lies outside the field (x {x0:g}..{x1:g}, y {y0:g}..{y1:g}): set the field's bounds"
    nx, ny, _ = rotation(yaw, pitch, roll)[:, 0]
    px, py = x + FACING_PROBE * nx, y + FACING_PROBE * ny
    if not (x0 < px < x1 and y0 < py < y1):
        return f"tag {tag_id} at ({x:g}, {y:g}) faces out of the field (yaw {yaw:g}): no camera on it can see it; is yaw off by pi?"
    return None
