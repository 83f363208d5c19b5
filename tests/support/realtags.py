"""Real photos of tag36h11 tags (tests/data/real-tags: two photos, CC BY-SA 2.0, README.md there) and their reference corners.

from tests.support.realtags import PHOTOS, reference, matched

for photo in PHOTOS:
    ref = reference(photo.with_suffix(".txt"))   # [(id, corners 4 x 2 [px]), ...] in zenav's Tag order and pixel convention
    hits = matched(ref, tags)                    # reference tags a detector found, every corner within 2 px
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from zenav.services.vps.detect import Tag

DATA = Path(__file__).resolve().parents[1] / "data" / "real-tags"
PHOTOS = sorted(DATA.glob("*.jpg"))
TOLERANCE = 2.0  # [px] a reference tag is found when every corner of a detection of its id is this close
_NUMBER = r"(-?\d+(?:\.\d+)?)"
_LINE = re.compile(r"^\s*(\d+)\s*," + r"\s*,".join([rf"\s*\(\s*{_NUMBER}\s+{_NUMBER}\s*\)"] * 4) + r"\s*$")


def parse(text: str) -> list[tuple[int, np.ndarray]]:
    """The reference tags of a .txt: `id, (x y), (x y), (x y), (x y)` a line, as the AprilTag 3 library reports them.

    The corners come in that library's order and pixel convention (pixel centres at halves); they are returned in
    zenav's Tag order and convention (top-left, top-right, bottom-right, bottom-left; centres at whole numbers), as
    detect.AprilTagDetector converts the library's. ValueError names a line that is not one."""
    out = []
    for n, line in enumerate(text.splitlines(), 1):
        if not line.strip():
            continue
        found = _LINE.match(line)
        if found is None:
            raise ValueError(f"line {n} is not `id, (x y), (x y), (x y), (x y)`: {line!r}")
        corners = np.array([float(v) for v in found.groups()[1:]]).reshape(4, 2)
        out.append((int(found.group(1)), corners[[1, 0, 3, 2]] - 0.5))
    return out


def reference(path: Path) -> list[tuple[int, np.ndarray]]:
    """The reference tags of one photo's .txt."""
    return parse(path.read_text())


def smallest_edge(ref: list[tuple[int, np.ndarray]]) -> float:
    """[px] the shortest edge of any reference tag."""
    return min(float(np.linalg.norm(c - np.roll(c, -1, axis=0), axis=1).min()) for _, c in ref)


def matched(ref: list[tuple[int, np.ndarray]], tags: list[Tag], tolerance: float = TOLERANCE) -> int:
    """How many reference tags a detection of the same id matches, corner by corner in order, within `tolerance` [px]."""
    return sum(any(t.id == i and np.linalg.norm(t.corners - c, axis=1).max() <= tolerance for t in tags) for i, c in ref)
