"""A service's timers and its calls at a time (`call_at`), on the stack clock."""

from __future__ import annotations

import heapq
import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, NamedTuple


@dataclass
class Timer:
    """A method run every `period` seconds of the stack clock (@timer)."""

    period: float  # [s]
    fn: Callable[[float], Any]
    due: float | None = None  # [s] stack time of its next run (None: a period after the first look)


class Call(NamedTuple):
    """A function run once when the stack clock reaches `t` (call_at)."""

    t: float  # [s] stack time
    order: int  # the order calls were asked in (of calls due at the same time, the first asked runs first)
    fn: Callable[[float], Any]


class Timers:
    """The timers and calls of one service: which are due, and how long until the next."""

    def __init__(self) -> None:
        self.timers: list[Timer] = []
        self.next_due = -math.inf  # [s] stack time of the earliest timer or call due (before it, none runs)
        self._calls: list[Call] = []  # a heap: the earliest first
        self._call_order = itertools.count()

    def every(self, period: float, fn: Callable[[float], Any]) -> None:
        """Run `fn(now)` every `period` seconds of the stack clock."""
        self.timers.append(Timer(period, fn))

    def call_at(self, t: float, fn: Callable[[float], Any]) -> bool:
        """Run `fn(now)` once when the stack clock reaches `t`. True: it is due before anything else (the worker
        may be waiting for a later timer)."""
        heapq.heappush(self._calls, Call(t, next(self._call_order), fn))
        if t < self.next_due or self.next_due == -math.inf:
            self.next_due = t
            return True
        return False

    def reset(self) -> None:
        """The stack clock started again: timers count their periods afresh, and calls are forgotten."""
        for tm in self.timers:
            tm.due = None
        self._calls.clear()
        self.next_due = -math.inf

    def run(self, now: float, fire: Callable[[Callable[[float], Any], float], None], overrun: Callable[[], None]) -> float | None:
        """Run (`fire`) the timers and calls due at `now`; return stack seconds until the next one (None: none).
        `overrun` is told each time a timer fell behind (its missed runs are skipped)."""
        if now < self.next_due:  # the common case, once per input: nothing due yet
            return self.next_due - now
        nearest = None
        for tm in self.timers:
            if tm.due is None:
                tm.due = now + tm.period
            if now >= tm.due:
                fire(tm.fn, now)
                tm.due += tm.period
                if tm.due <= now:  # fell behind: skip the missed runs rather than burst
                    overrun()
                    tm.due = now + tm.period
            left = tm.due - now
            nearest = left if nearest is None else min(nearest, left)
        due = []
        while self._calls and self._calls[0].t <= now:
            due.append(heapq.heappop(self._calls).fn)
        for fn in due:  # after taking them: a call made by one of them waits for the next look
            fire(fn, now)
        if self._calls:
            left = max(self._calls[0].t - now, 0.0)
            nearest = left if nearest is None else min(nearest, left)
        self.next_due = -math.inf if nearest is None else now + nearest
        return nearest
