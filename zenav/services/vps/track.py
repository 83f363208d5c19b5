"""Where to look for the robots' tags in a frame: a window around each tag's predicted place.

A tag seen in the last frames is looked for in a window around where its last two
sightings put it now (constant velocity in the image), wide enough for the tag and for
a robot at MAX_SPEED since then. The whole frame is searched every FULL_PERIOD (`due`: it
catches what a window cannot; the caller may do it once the frame's fixes are out), at
once, on the same frame, when a followed tag is not in its window (`lost`), and every
frame while a robot's tag is not followed (out of view): no fix is lost to the windows.
Pure: the caller runs the detector on the windows it is given.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from zenav.services.vps.detect import Tag

FULL_PERIOD = 2.0  # [s] of frame time between whole-frame searches
MAX_SPEED = 1.5  # [m/s] the fastest a robot is assumed to move between two frames
PAD = 8.0  # [px] added round each window (the prediction's error, the detector's edge)
WIDE = 0.5  # windows covering more of the frame than this: the whole frame is cheaper

Window = tuple[int, int, int, int]  # x0, y0, x1, y1 [px], x1 and y1 excluded


@dataclass(frozen=True)
class Seen:
    """One tag's last sighting."""

    t: float  # [s] frame time
    centre: tuple[float, float]  # [px]
    velocity: tuple[float, float]  # [px/s] from its two last sightings
    side: float  # [px] its mean edge


def centre(tag: Tag) -> tuple[float, float]:
    c = tag.corners.mean(axis=0)
    return float(c[0]), float(c[1])


def side(tag: Tag) -> float:
    return float(np.mean(np.linalg.norm(tag.corners - np.roll(tag.corners, 1, axis=0), axis=1)))


class Tracker:
    """The robots' tags followed from frame to frame in one camera's frames."""

    def __init__(self, width: int, height: int, tag_size: float) -> None:
        """`tag_size` [m]: the robots' tags' printed edge (the scale from pixels to metres near a tag)."""
        self.width, self.height, self.tag_size = width, height, tag_size
        self.seen: dict[int, Seen] = {}
        self.last_full = -math.inf  # [s] frame time of the last whole-frame search

    def due(self, t: float) -> bool:
        """Whether the frame of time t is due a whole search (FULL_PERIOD since the last, or time went back)."""
        return t - self.last_full >= FULL_PERIOD - 1e-9 or t < self.last_full  # frame times in tenths: rounding

    def windows(self, t: float, ids: Iterable[int]) -> list[Window] | None:
        """Where to look for tags `ids` in the frame of time t, or None: the whole frame, now (a tag of `ids` is not
        followed, or the windows would cover most of the frame)."""
        wanted = list(ids)
        followed = [self.seen[i] for i in wanted if i in self.seen]
        if len(followed) < len(wanted):
            return None  # a robot not followed (out of view, or not seen yet): it is looked for everywhere
        out = [self._window(s, t) for s in followed]
        area = sum((w[2] - w[0]) * (w[3] - w[1]) for w in out)
        return None if area > WIDE * self.width * self.height else out

    def _window(self, s: Seen, t: float) -> Window:
        dt = max(t - s.t, 0.0)
        x, y = s.centre[0] + s.velocity[0] * dt, s.centre[1] + s.velocity[1] * dt
        reach = s.side * (0.75 + MAX_SPEED * dt / self.tag_size) + PAD  # half its diagonal, and a fast robot's travel
        x0, y0 = max(int(x - reach), 0), max(int(y - reach), 0)
        return x0, y0, min(int(math.ceil(x + reach)) + 1, self.width), min(int(math.ceil(y + reach)) + 1, self.height)

    def lost(self, tags: list[Tag], ids: Iterable[int]) -> bool:
        """Whether a followed tag of `ids` is missing from `tags` (found in its window): search the whole frame now."""
        found = {t.id for t in tags}
        return any(i in self.seen and i not in found for i in ids)

    def update(self, t: float, tags: list[Tag], ids: Iterable[int], full: bool) -> None:
        """Note the tags of `ids` found in the frame of time t; `full`: the whole frame was searched (those not
        found are no longer followed)."""
        wanted = set(ids)
        found = {tag.id: tag for tag in tags if tag.id in wanted}
        for i, tag in found.items():
            c, old = centre(tag), self.seen.get(i)
            v = (0.0, 0.0)
            if old is not None and t > old.t:
                v = ((c[0] - old.centre[0]) / (t - old.t), (c[1] - old.centre[1]) / (t - old.t))
            self.seen[i] = Seen(t, c, v, side(tag))
        if full:
            self.last_full = t
            self.seen = {i: s for i, s in self.seen.items() if i in found}
