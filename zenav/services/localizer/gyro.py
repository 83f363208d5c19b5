"""The gyro's rate samples as a running integral, to cut into odom-sized increments."""

from __future__ import annotations

import bisect


class GyroIntegral:
    """Cumulative integral of a rate over the recent past, raw (bias and scale included): the gyro's yaw rate, or
    the accelerometer's forward reading (impact.py)."""

    def __init__(self, keep: float, max_gap: float) -> None:
        self.keep = keep  # [s] how far back increments can be asked for
        self.max_gap = max_gap  # [s] a longer silence restarts the integral
        self.t: list[float] = []  # [s] sample times, increasing
        self.angle: list[float] = []  # [rad] integral at each sample time

    @property
    def newest(self) -> float | None:
        """[s] the newest sample time (None: nothing yet)."""
        return self.t[-1] if self.t else None

    def add(self, t: float, rate: float) -> bool:
        """Take a sample (the rate over the span since the previous one); False if not newer."""
        if self.t and t <= self.t[-1]:
            return False
        if not self.t or t - self.t[-1] > self.max_gap:
            self.t, self.angle = [t], [0.0]
            return True
        self.angle.append(self.angle[-1] + rate * (t - self.t[-1]))
        self.t.append(t)
        cut = bisect.bisect_left(self.t, t - self.keep)
        if cut > 1:
            del self.t[: cut - 1], self.angle[: cut - 1]
        return True

    def _at(self, t: float) -> float:
        i = bisect.bisect_left(self.t, t)
        if self.t[i] == t:
            return self.angle[i]
        f = (t - self.t[i - 1]) / (self.t[i] - self.t[i - 1])
        return self.angle[i - 1] + f * (self.angle[i] - self.angle[i - 1])

    def between(self, a: float, b: float) -> float | None:
        """[rad] the integral over (a, b], or None when the samples do not cover it."""
        if not self.t or a < self.t[0] or b > self.t[-1]:
            return None
        return self._at(b) - self._at(a)
