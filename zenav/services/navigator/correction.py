"""The localizer's correction applied to odometry, as ROS's map -> odom transform: pure.

The localizer publishes a pose in the map frame for each odom sample, stamped with that
sample's t. The transform from the odometry's frame to the map frame at t is the
correction T = pose(t) o odom(t)^-1; applied to a later odom sample o, T o o is the
pose the localizer gives for o but for the correction's change between the two samples
(a fix, a set_pose, the localizer's own wheel model). `Pairing` keeps the newest odom
samples by t, pairs each pose with the sample of its t (either may come first), or with
the odometry interpolated at its t between the samples either side when the sample of
its t was skipped (a reader behind its input takes only the newest odom sample), and
keeps the correction of the newest pose paired: a jump of it (a fix) applies from the
next odom sample on.
"""

from __future__ import annotations

import math
from collections import deque
from enum import Enum
from typing import Generic, TypeVar

Frame = tuple[float, float, float]  # (x [m], y [m], theta [rad]): a pose, or a transform between two frames
P = TypeVar("P")  # what the caller keeps of a pose (the navigator: its message)

KEEP = 64  # odom samples kept to pair poses with (0.64 s at 100 Hz: a localizer that far behind is not paired)


def compose(a: Frame, b: Frame) -> Frame:
    """a o b: b's frame, given in a's, in a's parent frame."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return (a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], a[2] + b[2])


def inverse(a: Frame) -> Frame:
    """a^-1, so that compose(a, inverse(a)) is the identity."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return (-c * a[0] - s * a[1], s * a[0] - c * a[1], -a[2])


def correction(pose: Frame, odom: Frame) -> Frame:
    """The odometry's frame in the map frame, from the pose and the odom sample of one t."""
    return compose(pose, inverse(odom))


def between(a: tuple[float, Frame], b: tuple[float, Frame], t: float) -> Frame:
    """The odometry at t, linearly between the samples (t, odom) a and b (a's t < t < b's), the heading the short way."""
    f = (t - a[0]) / (b[0] - a[0])
    (ax, ay, ath), (bx, by, bth) = a[1], b[1]
    turn = math.remainder(bth - ath, math.tau)
    return (ax + f * (bx - ax), ay + f * (by - ay), ath + f * turn)


class Paired(Enum):
    """What became of a pose given to `Pairing.on_pose`."""

    PAIRED = "paired"  # its correction is the newest
    WAITING = "waiting"  # its odom sample has not come yet: paired when it comes
    OUT_OF_ORDER = "out of order"  # older than the pose of the correction: dropped
    UNPAIRED = "unpaired"  # older than every odom sample kept (too long ago), or no sample came before it: dropped


class Pairing(Generic[P]):
    """Odom samples and poses paired by t; the newest correction, and the pose it comes from."""

    def __init__(self, keep: int = KEEP) -> None:
        self._odom: deque[tuple[float, Frame]] = deque(maxlen=keep)  # (t, odom) in t order
        self._waiting: tuple[float, Frame, P] | None = None  # a pose whose odom sample has not come yet
        self.correction: Frame | None = None  # the odometry's frame in the map frame; None before the first pair
        self.pose: P | None = None  # what the caller gave with the pose of the correction
        self.t: float | None = None  # [s] t of the pose of the correction

    def on_odom(self, t: float, odom: Frame) -> Frame | None:
        """Keep an odom sample; its pose in the map frame, None before the first correction.
        ValueError if it is older than the newest sample (out of order: not kept)."""
        if self._odom and t < self._odom[-1][0]:
            raise ValueError(f"t {t:.3f} < {self._odom[-1][0]:.3f}")
        if self._odom and t == self._odom[-1][0]:
            self._odom.pop()  # a sample again: the newer one counts
        before = self._odom[-1] if self._odom else None
        self._odom.append((t, odom))
        w = self._waiting
        if w is not None and w[0] <= t:
            self._waiting = None
            if w[0] == t:
                self._pair(t, w[1], odom, w[2])
            elif before is not None and before[0] < w[0]:  # its own sample was skipped: the odometry between
                self._pair(w[0], w[1], between(before, (t, odom), w[0]), w[2])
        return None if self.correction is None else compose(self.correction, odom)

    def on_pose(self, t: float, pose: Frame, keep: P) -> Paired:
        """Pair a pose with the odom sample of its t (now or when it comes); `keep` is what `pose` gives back."""
        if self.t is not None and t < self.t:
            return Paired.OUT_OF_ORDER
        after: tuple[float, Frame] | None = None  # the oldest sample after t, as the samples are walked back
        for ot, odom in reversed(self._odom):
            if ot == t:
                self._pair(t, pose, odom, keep)
                return Paired.PAIRED
            if ot < t:
                if after is None:
                    break
                self._pair(t, pose, between((ot, odom), after, t), keep)  # its own sample was skipped
                return Paired.PAIRED
            after = (ot, odom)
        if not self._odom or t > self._odom[-1][0]:
            self._waiting = (t, pose, keep)
            return Paired.WAITING
        return Paired.UNPAIRED

    def reset(self) -> None:
        """Time started again (a sim restart): forget everything."""
        self._odom.clear()
        self._waiting, self.correction, self.pose, self.t = None, None, None, None

    def _pair(self, t: float, pose: Frame, odom: Frame, keep: P) -> None:
        self.correction, self.pose, self.t = correction(pose, odom), keep, t
        while self._odom and self._odom[0][0] < t:  # poses come in order: an older sample pairs with none
            self._odom.popleft()
