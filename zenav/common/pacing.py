"""Input held for a periodic topic (`@subscribe(..., after=topic)`).

An input declared `after` a periodic topic (`@subscribe("vps/pose", after="odom")`) is held while that topic flows
(its last sample served less than HOLD and a clock tick interval ago) and served by the worker in the middle of
the gap after that topic's next sample: work that may take milliseconds (a late fix's replay) then runs once that
sample's chain has gone on and before the following one comes, not in the way of either; and always before any
input after that sample. If that sample does not come, it is served once the stack clock is that far past its
arrival (or HOLD_WALL of wall time has passed with the clock still too: a paused sim). Both are judged on the
clock's ticks (`Clock.tick`), never extrapolated from the wall clock, so a replayed run gives the same results at
any speed, however a busy host delays the replay. A query is served only after what is held.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import NamedTuple

from zenav.common.clock import Clock
from zenav.common.intake import Input

# [s] stack clock: a topic flows while its last sample was served less than this and a tick interval ago
# (and an input `after` it waits as long at most)
HOLD = 0.05
HOLD_WALL = 1.0  # [s] wall: how long it waits at most when the stack clock does not move either (a sim paused, a replay at its end)
HOLD_ITEMS = 64  # inputs held at once at most (more are served at once)
GAP_GAIN = 0.2  # weight of each new gap in a topic's period (smoothed: one late sample does not move it far)


@dataclass
class Paced:
    """A topic that input is held for: when its samples were served, and how often they come."""

    last: float = -math.inf  # [s] wall time its last sample was served
    period: float = 0.0  # [s] wall, its smoothed period (0: not known yet)
    count: int = 0  # samples served
    tick: float = -math.inf  # [s] the stack clock's tick when the last was served


class Held(NamedTuple):
    """An input held for the gap after a sample of its topic."""

    waits_for: int  # the sample it waits for (that topic's count once served)
    came: float  # [s] wall time it came
    tick: float  # [s] the stack clock's tick it came at
    arrived: float  # [s] stack time it came
    item: Input  # served when released


class Pacer:
    """The held inputs of one service, and the topics they are held for."""

    def __init__(self, clock: Clock) -> None:
        self.clock = clock
        self.held_for: dict[str, str] = {}  # suffix -> the topic its input is held for (@subscribe after=)
        self.paced: dict[str, Paced] = {}  # topic held for -> its samples
        self.held: list[Held] = []  # oldest first

    def pace(self, suffix: str, after: str) -> None:
        """Hold input on `suffix` for the gaps of the periodic topic `after` (at start-up)."""
        self.held_for[suffix] = after
        self.paced[after] = Paced()

    def hold(self, after: str, item: Input) -> bool:
        """Hold an input for the gap after `after`'s next sample if that topic flows; False: serve it now."""
        paced = self.paced[after]
        now = self.clock.tick()
        if len(self.held) < HOLD_ITEMS and now < paced.tick + self.hold_span():  # it flows
            self.held.append(Held(paced.count + 1, time.monotonic(), now, self.clock.now(), item))
            return True
        return False

    def served(self, suffix: str) -> bool:
        """A sample on `suffix` was served: counted if input is held for its topic. True: held input's gap begins."""
        paced = self.paced.get(suffix)
        if paced is None:
            return False
        self._count_sample(paced)
        return bool(self.held) and self.waited()

    def take(self) -> list[Held]:
        """Every held input, oldest first; none is held after."""
        held, self.held = self.held, []
        return held

    def waited(self) -> bool:
        """The sample the oldest held input waits for has been served."""
        oldest = self.held[0]
        return self.paced[self.held_for[oldest.item.suffix]].count >= oldest.waits_for

    def overdue(self) -> bool:
        """The sample the oldest held input waits for has not come, and the stack clock has reached `_due`."""
        return self.clock.tick() >= self._due()

    def _due(self) -> float:
        """The tick at which the oldest held input stops waiting for the sample: `hold_span` past the tick it came at."""
        return self.held[0].tick + self.hold_span()

    def hold_span(self) -> float:
        """[s] of stack clock a topic flows after its last sample, and a held input waits at most: HOLD plus one
        tick interval (the sim's clock may tick slower than the topic: its next sample comes after the next tick)."""
        return HOLD + self.clock.resolution

    def _count_sample(self, paced: Paced) -> None:
        """A sample of a topic input is held for was served: its time, and the topic's period."""
        wall = time.monotonic()
        gap = wall - paced.last
        if gap < HOLD:  # a longer one is a pause, not the topic's period (wall: it only times the gap's middle)
            paced.period = gap if paced.period == 0.0 else paced.period + GAP_GAIN * (gap - paced.period)
        paced.last = wall
        paced.count += 1
        paced.tick = self.clock.tick()

    def wait(self) -> float:
        """Wall seconds until the oldest held input is due: the middle of the gap after the sample it waits for;
        if that sample has not come, when the stack clock reaches `_due` (looked at again then: a stalled sim
        clock does not get there) or, at the latest, HOLD_WALL after it came."""
        oldest = self.held[0]
        paced = self.paced[self.held_for[oldest.item.suffix]]
        last, gap = paced.last, paced.period
        wall = time.monotonic()
        if self.waited():
            return last + gap / 2.0 - wall
        if self.overdue():
            return 0.0
        until = self.clock.wall_delay(self._due() - self.clock.tick())
        return min(HOLD if until is None else until, oldest.came + HOLD_WALL - wall)
