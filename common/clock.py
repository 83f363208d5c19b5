"""The stack clock: one interface, four sources.

Services read time only through a Clock. `wall_delay` converts a span of clock time
into wall seconds so the runtime knows how long to block before the next timer.
"""
from __future__ import annotations

import math
import threading
import time
from typing import Optional, Protocol

from zenav.common.messages import Clock as ClockMsg


RESTART_JUMP = 1.0  # [s] a clock tick this far behind the last one means the sim restarted
FUTURE_LIMIT = 1.0  # [s] a message stamped further than this past now comes from a broken clock


class Clock(Protocol):
    def now(self) -> float:
        """Seconds on the stack clock."""

    @property
    def ready(self) -> bool:
        """Whether now() means anything yet (a sim clock waits for its first tick)."""

    def wall_delay(self, dt: float) -> Optional[float]:
        """Wall seconds until `dt` clock seconds pass (None: time only moves when told)."""

    def horizon(self) -> float:
        """The latest time a message may carry now: a later stamp is dropped as from the future."""


class WallClock:
    """Real hardware: the host's wall clock (epoch seconds)."""

    ready = True

    def now(self) -> float:
        return time.time()

    def wall_delay(self, dt: float) -> Optional[float]:
        return max(dt, 0.0)

    def horizon(self) -> float:
        return self.now() + FUTURE_LIMIT


class ScaledWallClock:
    """The sim's own schedule: wall time scaled by the realtime factor, from t0."""

    ready = True

    def __init__(self, rtf: float = 1.0, t0: float = 0.0) -> None:
        self.rtf = rtf
        self._t0 = t0
        self._start = time.monotonic()

    def now(self) -> float:
        return self._t0 + (time.monotonic() - self._start) * self.rtf

    def wall_delay(self, dt: float) -> Optional[float]:
        return max(dt, 0.0) / self.rtf

    def horizon(self) -> float:
        return self.now() + FUTURE_LIMIT * max(1.0, self.rtf)


class SimClock:
    """Follows the sim's `clock` topic, extrapolating between ticks.

    Between two ticks, now() advances with the wall clock at the sim's realtime
    factor (processes on one host share that clock), but never more than
    `max_extrapolation` wall seconds past the last tick: a stopped sim stops time.
    """

    def __init__(self, max_extrapolation: float = 0.05) -> None:
        self._lock = threading.Lock()
        self._t: Optional[float] = None
        self._wall = 0.0
        self._rtf = 1.0
        self._last = 0.0
        self._max_ext = max_extrapolation

    @property
    def ready(self) -> bool:
        return self._t is not None

    def update(self, msg: ClockMsg) -> bool:
        """Take a tick from the `clock` topic; True if time jumped back (the sim restarted)."""
        with self._lock:
            restarted = self._t is not None and msg.t < self._t - RESTART_JUMP
            if restarted:
                self._last = 0.0  # time starts again
            self._t, self._rtf = msg.t, msg.rtf
            self._wall = msg.wall if msg.wall > 0 else time.time()
            return restarted

    def now(self) -> float:
        with self._lock:
            if self._t is None:
                return 0.0
            ext = min(max(time.time() - self._wall, 0.0), self._max_ext)
            self._last = max(self._last, self._t + ext * self._rtf)
            return self._last

    def wall_delay(self, dt: float) -> Optional[float]:
        return max(dt, 0.0) / self._rtf

    def horizon(self) -> float:
        """Before the first tick nothing is known to be from the future."""
        if not self.ready:
            return math.inf
        return self.now() + FUTURE_LIMIT * max(1.0, self._rtf)


class ManualClock:
    """A clock that tests set and advance."""

    ready = True

    def __init__(self, t: float = 0.0) -> None:
        self.t = t

    def now(self) -> float:
        return self.t

    def advance(self, dt: float) -> float:
        self.t += dt
        return self.t

    def wall_delay(self, dt: float) -> Optional[float]:
        return None

    def horizon(self) -> float:
        """Tests set time by hand and may send messages ahead of it."""
        return math.inf
