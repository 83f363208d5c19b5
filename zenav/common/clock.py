"""The stack clock: one interface, four sources.

Services read time only through a Clock. `wall_delay` converts a span of clock time
into wall seconds so the runtime knows how long to block before the next timer.
"""

from __future__ import annotations

import math
import threading
import time
from typing import Protocol

from zenav.common.messages import Clock as ClockMsg

RESTART_JUMP = 1.0  # [s] a tick from the clock's owner this far behind the last one is refused (a replay's made ticks start again)
FUTURE_STAMP = 0.1  # [s] default lead a message's stamp may have over the clock ([limits] future_stamp)
CLOCK_JUMP = 1.0  # [s] default for how far a tick may run past the rtf's pace ([limits] clock_jump)
MAX_RTF = 100.0  # [-] the highest realtime factor a sim runs at (the [sim] rtf limit)
PACE_MARGIN = 2.0  # [-] a tick may advance this many times the rtf's pace over the wall time since the last
REFUSED_RUN = 20  # ticks refused in a row that agree with each other are a new timeline, taken as a restart

ACCEPTED, RESTARTED, REFUSED, FOREIGN = "accepted", "restarted", "refused", "foreign"


class Clock(Protocol):
    def now(self) -> float:
        """Seconds on the stack clock."""

    def tick(self) -> float:
        """The stack time of the newest tick, never extrapolated: what has been heard, so the same in a
        replay at any speed (a sim clock's last tick; now() for a clock that does not tick)."""

    @property
    def resolution(self) -> float:
        """[s] how far the stack time may be past tick(): a sim clock's tick interval (0: read continuously)."""

    @property
    def ready(self) -> bool:
        """Whether now() means anything yet (a sim clock waits for its first tick)."""

    def wall_delay(self, dt: float) -> float | None:
        """Wall seconds until `dt` clock seconds pass (None: time only moves when told)."""

    def admits(self, t: float) -> bool:
        """Whether a message stamped t may be taken now: not past the clock's horizon (the latest
        time a message may carry now; a later stamp is dropped as from the future)."""


class WallClock:
    """Real hardware: the host's wall clock (epoch seconds)."""

    ready = True
    resolution = 0.0

    def __init__(self, future: float = FUTURE_STAMP) -> None:
        self._future = future  # [s]

    def now(self) -> float:
        return time.time()

    def tick(self) -> float:
        return time.time()

    def wall_delay(self, dt: float) -> float | None:
        return max(dt, 0.0)

    def admits(self, t: float) -> bool:
        return t <= time.time() + self._future


class ScaledWallClock:
    """The sim's own schedule: wall time scaled by the realtime factor, from t0."""

    ready = True
    resolution = 0.0

    def __init__(self, rtf: float = 1.0, t0: float = 0.0, future: float = FUTURE_STAMP) -> None:
        self.rtf = rtf
        self._future = future  # [s]
        self._t0 = t0
        self._start = time.monotonic()

    def now(self) -> float:
        return self._t0 + (time.monotonic() - self._start) * self.rtf

    def tick(self) -> float:
        return self.now()

    def wall_delay(self, dt: float) -> float | None:
        return max(dt, 0.0) / self.rtf

    def admits(self, t: float) -> bool:
        return t <= self.now() + self._future * max(1.0, self.rtf)


class SimClock:
    """Follows the sim's `clock` topic, extrapolating between ticks.

    Between two ticks, now() advances with the wall clock at the sim's realtime
    factor (processes on one host share that clock), but never more than
    `max_extrapolation` wall seconds, nor one tick interval, past the last tick: a
    stopped sim stops time, and at a high rtf the interpolation cannot run ahead
    of the ticks (a stamp is judged against the sim's own steps).

    Only the clock's owner moves time: the sim instance whose token
    (`zenav/<robot>/instance/sim/<id>`, told by `sim_token`) is alive, named in each tick
    (`instance`). The first sender is the owner; another takes over only once the owner's
    token is gone, and only if its own token is alive (or no sim's token is: a replay into a
    stack without a sim). A new owner is a sim restart: time starts again from its tick. A
    tick from any other sender (a replay, a client, a second sim that slipped in) is
    FOREIGN (`foreign` counts them) and changes nothing.

    Time moves only by plausible ticks of the owner: a tick with an rtf above MAX_RTF or
    other than the current one, one further ahead than `jump` plus twice the rtf's pace
    over the wall time since the last tick, or one more than RESTART_JUMP behind the last,
    is refused (`refused` counts them). A run of REFUSED_RUN refused ticks of the owner that
    agree with each other is a new timeline, taken as a restart.
    """

    def __init__(self, max_extrapolation: float = 0.25, future: float = FUTURE_STAMP, jump: float = CLOCK_JUMP) -> None:
        self._lock = threading.Lock()
        self._t: float | None = None
        self._wall = 0.0
        self._rtf = 1.0
        self._last = 0.0
        self._max_ext = max_extrapolation  # [s] wall
        self._future, self._jump = future, jump  # [s]
        self._step = jump  # [s] the latest tick interval: a sample may lead the clock by one
        self._seen = 0.0  # [s] monotonic time the last tick was taken
        self._refused_run: list[ClockMsg] = []  # the refused ticks in a row
        self._sims: set[str] = set()  # the sim instances whose tokens are alive
        self.owner: str | None = None  # the instance whose ticks move time (None: no tick taken yet)
        self.refused = 0  # ticks refused so far
        self.foreign = 0  # ticks from another sender than the owner
        self.refusal = ""  # why the last tick refused or foreign was

    def sim_token(self, instance: str, alive: bool) -> None:
        """A sim instance's token came (`alive`) or went."""
        with self._lock:
            (self._sims.add if alive else self._sims.discard)(instance)

    def _takes_over(self, instance: str) -> bool | None:
        """Whether a tick's sender is the owner (False), a new owner (True) or foreign (None)."""
        if instance == self.owner:
            return False
        if self.owner is not None and self.owner in self._sims:
            return None  # the owner lives
        if self._sims and instance not in self._sims:
            return None  # a sim lives, and this is not it
        return True

    @property
    def ready(self) -> bool:
        return self._t is not None

    def update(self, msg: ClockMsg) -> str:
        """Take a tick from the `clock` topic: ACCEPTED, RESTARTED (a new owner, or a new timeline), REFUSED
        or FOREIGN (not the owner's)."""
        with self._lock:
            takes_over = self._takes_over(msg.instance)
            if takes_over is None:
                self.foreign += 1
                self.refusal = f"sent by {msg.instance or 'a sender without an instance id'}, not by the clock's owner {self.owner}"
                return FOREIGN
            seen = time.monotonic()
            why = self._implausible(msg, seen)
            restarted = takes_over and self._t is not None and msg.rtf <= MAX_RTF
            if why is not None and not restarted:
                run = self._refused_run
                if run and self._plausible_after(run[-1], msg):
                    run.append(msg)
                else:
                    run[:] = [msg]
                if len(run) < REFUSED_RUN:
                    self.refused += 1
                    self.refusal = why
                    return REFUSED
                restarted = True  # a new timeline, not a glitch
            self._refused_run = []
            self.owner = msg.instance
            if restarted:
                self._last, self._step = 0.0, self._jump  # time starts again
            elif self._t is not None and msg.t > self._t:
                self._step = min(msg.t - self._t, self._jump)
            self._t, self._rtf, self._seen = msg.t, msg.rtf, seen
            self._wall = msg.wall if msg.wall > 0 else time.time()
            return RESTARTED if restarted else ACCEPTED

    def _implausible(self, msg: ClockMsg, seen: float) -> str | None:
        """Why a tick cannot follow the current one, or None."""
        if msg.rtf > MAX_RTF:
            return f"rtf {msg.rtf:g} is above {MAX_RTF:g}"
        if self._t is None:
            return None
        if msg.rtf != self._rtf:
            return f"rtf changed from {self._rtf:g} to {msg.rtf:g} without a restart"
        if msg.t < self._t - RESTART_JUMP:
            return f"t went back {self._t - msg.t:.3f} s without a new clock owner (a sim restart is a new instance)"
        allowed = self._jump + PACE_MARGIN * self._rtf * max(seen - self._seen, 0.0)
        if msg.t - self._t > allowed:
            return f"t jumped {msg.t - self._t:.3f} s ahead (at most {allowed:.3f} s is plausible)"
        return None

    def _plausible_after(self, prev: ClockMsg, msg: ClockMsg) -> bool:
        return msg.rtf == prev.rtf and prev.t <= msg.t <= prev.t + self._jump

    def now(self) -> float:
        with self._lock:
            if self._t is None:
                return 0.0
            ext = min(max(time.time() - self._wall, 0.0), self._max_ext) * self._rtf
            self._last = max(self._last, self._t + min(ext, self._step))
            return self._last

    def tick(self) -> float:
        t = self._t
        return 0.0 if t is None else t

    @property
    def resolution(self) -> float:
        return self._step

    def wall_delay(self, dt: float) -> float | None:
        return max(dt, 0.0) / self._rtf

    def horizon(self) -> float:
        """The clock, plus one tick (a sensor sample goes out just before its tick), plus `future`.

        Before the first tick nothing is known to be from the future.
        """
        if not self.ready:
            return math.inf
        return self.now() + self._step + self._future

    def admits(self, t: float) -> bool:
        """Without the lock or a clock read when t is under the lowest the horizon can be now (the
        newest tick or reading, plus a tick, plus `future`): the common case, once per input."""
        last = self._t
        if last is None or t <= max(last, self._last) + self._step + self._future:
            return True
        return t <= self.horizon()


class ManualClock:
    """A clock that tests set and advance."""

    ready = True
    resolution = 0.0

    def __init__(self, t: float = 0.0) -> None:
        self.t = t

    def now(self) -> float:
        return self.t

    def tick(self) -> float:
        return self.t

    def advance(self, dt: float) -> float:
        self.t += dt
        return self.t

    def wall_delay(self, dt: float) -> float | None:
        return None

    def admits(self, t: float) -> bool:
        """Tests set time by hand and may send messages ahead of it."""
        return True
