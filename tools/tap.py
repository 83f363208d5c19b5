"""Every sample under a key expression, handed in arrival order to one worker thread.

Zenoh runs subscription callbacks on its own threads, and a slow callback stalls the
session, so the callback only stamps and enqueues; the worker does the real work
(writing a file, feeding a viewer).
"""
from __future__ import annotations

import logging
import queue
import threading
import time
from typing import Callable, Optional

from zenav.common.bus import Bus, Handle

QUEUE_LIMIT = 100_000  # samples waiting for the worker; beyond that new ones are dropped and counted

Handler = Callable[[str, bytes, int], None]  # (key, payload, wall time of arrival [ns])

log = logging.getLogger("zenav.tools")


class Tap:
    """Subscribe to `keyexpr` and run `handler(key, payload, wall_ns)` on one worker thread."""

    def __init__(self, bus: Bus, keyexpr: str, handler: Handler, name: str = "tap") -> None:
        self.bus, self.keyexpr, self.handler = bus, keyexpr, handler
        self.dropped = 0  # samples lost to a full queue
        self.errors = 0  # samples the handler failed on
        self._queue: queue.Queue = queue.Queue(QUEUE_LIMIT)
        self._worker = threading.Thread(target=self._run, name=f"zenav-{name}", daemon=True)
        self._sub: Optional[Handle] = None

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
        self._queue.put(None)
        self._worker.join(timeout)

    def _enqueue(self, key: str, data: bytes) -> None:
        try:
            self._queue.put_nowait((key, data, time.time_ns()))
        except queue.Full:
            self.dropped += 1

    def _run(self) -> None:
        while (item := self._queue.get()) is not None:
            try:
                self.handler(*item)
            except Exception:
                self.errors += 1
                log.exception("%s: handling a sample on %s failed", self._worker.name, item[0])
