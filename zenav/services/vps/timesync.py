"""The camera host's clock against the stack's: offset and drift from query round trips.

Pure. The camera host (the vps) asks the stack (`time/sync`, served by the localizer) for
its clock now and then: it reads its own clock when the query goes (`sent`) and when the
reply comes (`received`). The stack's reading was taken somewhere in between, so
`stack - (sent + received) / 2` is the offset, wrong by at most half the round trip
(Cristian's algorithm, as NTP and PhotonVision's time sync use it). Round trips that
waited in a queue on the way are the worst: of the last WINDOW exchanges only the
quickest half are fitted, a straight line of the
offset over the host's time, whose slope is the drift (a crystal's 10-100 ppm: 0.1 ms
a second). With too few or too short a span for a slope, the quickest one's offset alone.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

WINDOW = 30  # exchanges kept (one a second: half a minute)
KEEP = 0.5  # the quickest half of the exchanges kept are fitted (at least MIN_FIT)
MIN_FIT = 3  # exchanges a drift is fitted to at least
MIN_SPAN = 5.0  # [s] of host time the fitted exchanges span at least for a drift to be fitted
MAX_DRIFT = 1e-3  # a fitted drift over 1000 ppm is not a clock's: the offset alone is used
MAX_RTT = 0.5  # [s] a longer round trip is refused: it places the stack's reading too loosely


@dataclass(frozen=True)
class Exchange:
    """One round trip: the host's clock when the query went and when the reply came, the stack's in between."""

    sent: float  # [s] host clock
    stack: float  # [s] stack clock in the reply
    received: float  # [s] host clock

    @property
    def rtt(self) -> float:
        return self.received - self.sent

    @property
    def mid(self) -> float:
        return (self.sent + self.received) / 2.0

    @property
    def offset(self) -> float:
        """[s] stack clock minus host clock."""
        return self.stack - self.mid


class TimeSync:
    """Maps the host's clock to the stack's, from the exchanges added."""

    def __init__(self) -> None:
        self.exchanges: deque[Exchange] = deque(maxlen=WINDOW)
        self.offset = 0.0  # [s] stack minus host at host time `ref`
        self.drift = 0.0  # [s/s] the offset's change per host second
        self.ref = 0.0  # [s] host time
        self.rtt = float("nan")  # [s] the quickest round trip kept

    @property
    def ready(self) -> bool:
        """Whether one exchange at least has been kept."""
        return bool(self.exchanges)

    def add(self, ex: Exchange) -> str:
        """Keep one exchange and fit again; "" or why it was refused."""
        if not 0.0 <= ex.rtt <= MAX_RTT:
            return f"round trip {ex.rtt * 1e3:.1f} ms is not within 0..{MAX_RTT * 1e3:.0f} ms"
        if self.exchanges and ex.sent < self.exchanges[-1].sent:
            self.exchanges.clear()  # the host's clock went back (set by hand, or the sim restarted)
        self.exchanges.append(ex)
        self._fit()
        return ""

    def _fit(self) -> None:
        quick = sorted(self.exchanges, key=lambda e: e.rtt)
        kept = quick[: max(MIN_FIT, round(len(quick) * KEEP))]
        self.rtt = quick[0].rtt
        t = np.array([e.mid for e in kept])
        off = np.array([e.offset for e in kept])
        self.ref = float(t.mean())
        if len(kept) >= MIN_FIT and t.max() - t.min() >= MIN_SPAN:
            slope, intercept = np.polyfit(t - self.ref, off, 1)
            if abs(slope) <= MAX_DRIFT:
                self.offset, self.drift = float(intercept), float(slope)
                return
        self.offset, self.drift, self.ref = quick[0].offset, 0.0, quick[0].mid

    def to_stack(self, t_host: float) -> float:
        """[s] the stack's clock when the host's read t_host."""
        return t_host + self.offset + self.drift * (t_host - self.ref)
