"""A pose time series and the pose interpolated at any instant: the one way truth is read at t.

Scores, plots and live views judge an estimate against the truth at the estimate's own
t (odom at its encoder sample, pose at its odom t, a fix at its capture time), so all
of them interpolate the same way: x and y linearly, the heading along the shorter arc.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import cast

import numpy as np

Sample = tuple[float, float, float, float]  # (t [s], x [m], y [m], theta [rad])


class Track:
    """Samples (t, x, y, theta) sorted by t; `at` interpolates, clamped to the first and last."""

    def __init__(self, samples: Iterable[Sample]) -> None:
        a = np.array(sorted(samples), dtype=float).reshape(-1, 4)
        self.t, self.x, self.y = a[:, 0], a[:, 1], a[:, 2]
        self._theta = np.unwrap(a[:, 3]) if len(a) else a[:, 3]  # continuous, so interpolation takes the short way

    def __len__(self) -> int:
        return len(self.t)

    def covers(self, t: np.ndarray) -> np.ndarray:
        """Which instants lie inside the track's time span."""
        if not len(self.t):
            return np.zeros(np.shape(t), dtype=bool)
        return cast(np.ndarray, (t >= self.t[0]) & (t <= self.t[-1]))

    def at_many(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(x, y, theta) at each instant of `t` (theta wrapped to (-pi, pi])."""
        th = np.interp(t, self.t, self._theta)
        return np.interp(t, self.t, self.x), np.interp(t, self.t, self.y), np.pi - (np.pi - th) % (2 * np.pi)

    def at(self, t: float) -> tuple[float, float, float]:
        """(x [m], y [m], theta [rad]) at `t` [s]."""
        x, y, th = self.at_many(np.array([t]))
        return float(x[0]), float(y[0]), float(th[0])

    def errors(self, est: Iterable[Sample]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(t, position error [m], |heading error| [rad]) of `est` at its own t, inside the track's span."""
        e = np.array(sorted(est), dtype=float).reshape(-1, 4)
        if len(self) < 2:
            e = e[:0]
        e = e[self.covers(e[:, 0])]
        x, y, th = self.at_many(e[:, 0])
        dth = (e[:, 3] - th + math.pi) % (2 * math.pi) - math.pi
        return e[:, 0], np.hypot(e[:, 1] - x, e[:, 2] - y), np.abs(dth)
