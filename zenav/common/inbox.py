"""A service's input queue: a priority lane before the normal one, bounded in items and bytes.

Bus threads put; the one worker takes (one worker may serve several inboxes that share
one condition: runtime.Executor). Items of the priority lane (e.g. nav/stop) are
taken before anything in the normal lane, whatever is queued there. A put that would
pass either bound is refused (the caller counts it); the priority lane has its own
item bound so that a flood of normal input cannot keep a stop out.

An input of which only the newest is worth serving (a camera's frames: a detector slower
than the camera must read the newest frame, not fall further behind with every one) is
put with `put_latest`: one still queued under the same key is replaced by it, in its
place, so such an input never holds more than one place in the queue.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Hashable
from typing import Any, Literal


class Inbox:
    """Two FIFO lanes under one lock; `get` prefers the priority lane."""

    def __init__(self, max_items: int, max_bytes: int, ready: threading.Condition | None = None) -> None:
        self.max_items, self.max_bytes = max_items, max_bytes  # [items], [bytes] of the normal lane
        self._lanes: tuple[deque[list[Any]], deque[list[Any]]] = (
            deque(),
            deque(),
        )  # (priority, normal) of [item, size, latest key or None]
        self._bytes = 0  # [bytes] queued in both lanes
        self._latest: dict[Hashable, list[Any]] = {}  # key -> its queued entry (put_latest)
        self._poked = False  # poke() since the worker last looked (idle)
        # Inboxes of services that share one worker share this condition: a put wakes that worker.
        self._ready = ready or threading.Condition(threading.Lock())

    def put(self, item: Any, size: int = 0, priority: bool = False) -> bool:
        """Queue an item of `size` bytes; False (not queued) when it would pass a bound."""
        with self._ready:
            return self._append([item, size, None], priority)

    def put_latest(self, key: Hashable, item: Any, size: int = 0) -> Literal["queued", "replaced", "refused"]:
        """Queue an item of the normal lane of which only the newest under `key` is worth serving: one still
        queued under `key` is dropped for it ("replaced": it takes that one's place), else as `put`."""
        with self._ready:
            entry = self._latest.get(key)
            if entry is None:
                entry = [item, size, key]
                if not self._append(entry, priority=False):
                    return "refused"
                self._latest[key] = entry
                return "queued"
            if self._bytes - entry[1] + size > self.max_bytes:
                return "refused"
            self._bytes += size - entry[1]
            entry[0], entry[1] = item, size
            return "replaced"

    def _append(self, entry: list[Any], priority: bool) -> bool:
        """Append [item, size, latest key or None] to its lane unless it would pass a bound (the lock held)."""
        lane, size = self._lanes[0 if priority else 1], entry[1]
        if len(lane) >= self.max_items or (not priority and self._bytes + size > self.max_bytes):
            return False
        lane.append(entry)
        self._bytes += size
        self._ready.notify()
        return True

    def get(self, timeout: float | None = None) -> tuple[bool, Any]:
        """(True, item), priority lane first, waiting up to `timeout` s (None: do not wait); (False, None) if empty."""
        deadline = None if timeout is None else time.monotonic() + timeout
        with self._ready:
            while not (self._lanes[0] or self._lanes[1]):
                left = 0.0 if deadline is None else deadline - time.monotonic()
                if left <= 0.0:
                    return False, None
                self._ready.wait(left)
            item, size, key = (self._lanes[0] or self._lanes[1]).popleft()
            self._bytes -= size
            if key is not None:
                del self._latest[key]
            return True, item

    def poke(self) -> None:
        """Wake the worker waiting on this inbox, to look again at what it has to do; if it is not
        waiting yet, its next wait returns at once (a poke is never lost between a look and a wait)."""
        with self._ready:
            self._poked = True
            self._ready.notify()

    def wait(self, timeout: float) -> None:
        """Block until something is queued or poked, or `timeout` s passed."""
        with self._ready:
            if self.idle():
                self._ready.wait(timeout)

    def idle(self) -> bool:
        """Nothing queued and no poke since the last look (the condition's lock held: a worker about to wait)."""
        poked, self._poked = self._poked, False
        return not poked and self.empty()

    def empty(self) -> bool:
        """Nothing queued in either lane."""
        return not (self._lanes[0] or self._lanes[1])

    def qsize(self) -> int:
        """Items queued in both lanes."""
        return len(self._lanes[0]) + len(self._lanes[1])

    def nbytes(self) -> int:
        """Bytes queued in both lanes."""
        return self._bytes
