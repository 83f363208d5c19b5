"""What a service tells in diag: its counters, message rates, time spent serving, CPU share and status; and
warnings logged a few lines a second per kind at most."""

from __future__ import annotations

import re
import time
from dataclasses import dataclass, field
from typing import NamedTuple

_FIGURES = re.compile(r"\d+(\.\d+)?")  # the figures of a status reason
WARN_LINES = 5  # lines of one kind of warning logged before they are thinned
WARN_EVERY = 5.0  # [s] wall: then one line of that kind at most this often


@dataclass
class ServeTime:
    """The time a topic's messages took to serve since the last diag."""

    seconds: float = 0.0  # [s] wall
    count: int = 0  # messages


@dataclass
class Counters:
    """Counters and per-topic message counts, published in diag."""

    values: dict[str, int] = field(
        default_factory=lambda: dict.fromkeys(
            ("msgs_in", "msgs_out", "bad_input", "dropped_stale", "dropped_future", "oversize", "errors"), 0
        )
    )
    window: dict[str, int] = field(default_factory=dict)  # topic -> messages since the last diag
    serve: dict[str, ServeTime] = field(default_factory=dict)  # topic -> time serving its messages since the last diag

    def inc(self, name: str, n: int = 1) -> None:
        self.values[name] = self.values.get(name, 0) + n

    def seen(self, topic: str) -> None:
        self.window[topic] = self.window.get(topic, 0) + 1

    def served(self, topic: str, seconds: float) -> None:
        """A message of `topic` took `seconds` to serve."""
        spent = self.serve.get(topic)
        if spent is None:
            spent = self.serve[topic] = ServeTime()
        spent.seconds += seconds
        spent.count += 1

    def take_rates(self, span: float) -> dict[str, float]:
        """Messages per second of each topic over `span` seconds, since the last diag (counted afresh from now)."""
        rates = {k: round(v / span, 2) for k, v in self.window.items()}
        self.window = {}
        return rates

    def take_serve(self) -> dict[str, float]:
        """[us] the mean time a message of each topic took to serve since the last diag (counted afresh from now)."""
        serve = {k: round(spent.seconds / spent.count * 1e6, 1) for k, spent in self.serve.items()}
        self.serve = {}
        return serve


class CpuMark(NamedTuple):
    wall: float  # [s] monotonic
    cpu: float  # [s] process CPU time


class CpuMeter:
    """The share of a core this process used between two reads."""

    def __init__(self, wall: float) -> None:
        self._mark = CpuMark(wall, time.process_time())

    def busy(self) -> float:
        """Cores busy since the last read (or the start)."""
        wall, cpu = time.monotonic(), time.process_time()
        busy = (cpu - self._mark.cpu) / max(wall - self._mark.wall, 1e-3)
        self._mark = CpuMark(wall, cpu)
        return busy


@dataclass
class Warned:
    count: int = 0  # warnings of this kind
    last: float = 0.0  # [s] wall (monotonic) time of the last line logged


class WarnLimit:
    """Which warnings to log: the first few of each kind, then one every few seconds (the counters keep the rest)."""

    def __init__(self) -> None:
        self._warned: dict[str, Warned] = {}  # warning kind -> how many, and when the last was logged

    def admit(self, kind: str) -> int | None:
        """Count a warning of `kind`; the number of them so far if it is to be logged, None if not."""
        now = time.monotonic()
        seen = self._warned.setdefault(kind, Warned())
        seen.count += 1
        if seen.count <= WARN_LINES or now - seen.last >= WARN_EVERY:
            seen.last = now
            return seen.count
        return None


def shape(text: str) -> str:
    """A status reason with its figures blanked: what it says, not how much."""
    return _FIGURES.sub("#", text)
