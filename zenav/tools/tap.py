"""Every sample under a key expression, handed in arrival order to one worker thread.

Zenoh runs subscription callbacks on its own threads, and a slow callback stalls the
session, so the callback only stamps and enqueues; the worker does the real work
(writing a file, feeding a viewer). An optional `tick` runs on the same worker every
`period` seconds, busy or idle (a recorder flushing its file).
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from collections.abc import Callable
from typing import Any

from zenav.common.bus import Bus, Handle

QUEUE_LIMIT = 100_000  # samples waiting for the worker; beyond that new ones are dropped and counted

Handler = Callable[[str, bytes, int], None]  # (key, payload, wall time of arrival [ns])
Tick = Callable[[], None]

log = logging.getLogger("zenav.tools")


class Tap:
    """Subscribe to `keyexpr` and run `handler(key, payload, wall_ns)` on one worker thread."""

    def __init__(self, bus: Bus, keyexpr: str, handler: Handler, name: str = "tap", tick: Tick | None = None, period: float = 1.0) -> None:
        """`tick` (if any) runs on the worker every `period` [s] of wall time."""
        self.bus, self.keyexpr, self.handler = bus, keyexpr, handler
        self.tick, self.period = tick, period
        self.dropped = 0  # samples lost to a full queue
        self.errors = 0  # samples the handler failed on
        self._queue: queue.Queue[Any] = queue.Queue(QUEUE_LIMIT)
        self._worker = threading.Thread(target=self._run, name=f"zenav-{name}", daemon=True)
        self._sub: Handle | None = None

    def start(self) -> Tap:
        """Start the worker, then subscribe."""
        self._worker.start()
        self._sub = self.bus.subscribe(self.keyexpr, self._enqueue)
        return self

    def stop(self, timeout: float = 30.0) -> None:
        """Unsubscribe, let the worker finish everything already queued, and join it."""
        if self._sub is not None:
            self._sub.undeclare()
            self._sub = None
        if self._worker.ident is not None:  # started
            self._queue.put(None)
            self._worker.join(timeout)

    def _enqueue(self, key: str, data: bytes) -> None:
        try:
            self._queue.put_nowait((key, data, time.time_ns()))
        except queue.Full:
            self.dropped += 1

    def _run(self) -> None:
        due = time.monotonic() + self.period
        while True:
            try:
                item = self._queue.get(timeout=max(due - time.monotonic(), 0.0) if self.tick else None)
            except queue.Empty:
                item = ()  # time for the tick
            if item is None:
                return
            try:
                if item:
                    self.handler(*item)
                if self.tick is not None and time.monotonic() >= due:
                    due = time.monotonic() + self.period
                    self.tick()
            except Exception:
                self.errors += 1
                log.exception("%s: handling %s failed", self._worker.name, item[0] if item else "the tick")
