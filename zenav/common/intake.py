"""A service's intake: what the bus's threads bring (samples, queries, tokens, clock ticks), its size checked before
anything is decoded, then served at once on that thread (`inline`) or queued for the worker.

Queries declared `priority` (and liveliness events) go in a lane the worker empties before anything else, so a
stop is never queued behind other input; on Zenoh they are served on a session of their own (bus.ZenohBus), so a
stop is not behind other input on the wire either. Before the worker gets to it, such a query (on its exact key)
runs the service's `on_priority` hook at once on the bus's thread: the navigator commands zero there, without
waiting for the input the worker has in hand. Every query is numbered as it arrives, in the bus callback
(`query_arrival`): the order in which queries reached the service, which a priority query's overtaking does not
change (the navigator voids the goals that arrived before a stop). The queue is bounded in items and bytes
([limits]): a full one drops new input (`dropped_overflow`). An input declared `latest`
(`@subscribe("camera/frame", latest=True)`, as ROS 2's keep-last depth 1) holds one place in the queue at most: a
sample that comes while its topic's previous one is still queued takes that one's place, and the older is dropped,
counted (`dropped_superseded`) and logged. A service slower than such an input serves its newest sample each time,
rather than falling further behind with every one.

Sizes are checked in the bus callback, before anything is decoded: a payload over [limits] max_payload or selector
parameters over max_params are counted (`oversize`), logged and dropped (a query is answered `invalid_argument`).
"""

from __future__ import annotations

import functools
import itertools
import threading
from collections.abc import Callable
from typing import Any, NamedTuple

from zenav.common import messages as m
from zenav.common.bus import Query
from zenav.common.config import Limits
from zenav.common.contract import ErrorCode, Reason
from zenav.common.diagnostics import Counters
from zenav.common.inbox import Inbox
from zenav.common.replies import reply_error


class Input(NamedTuple):
    """One input as queued for a service's worker."""

    kind: str  # msg (a topic's sample), clock (the sim's clock), query, live (a liveliness token came or went)
    fn: Callable[..., Any]  # its handler
    suffix: str  # the topic's suffix; an acting query's exact key ("": any key); a token's key
    typ: type  # what its payload decodes as (a token's change: bool, its alive)
    data: Any  # the payload; a query's (Query, its arrival number); a token's alive (bool)


class Intake:
    """The bus callbacks of a Service (a part of it: the state is the service's)."""

    name: str
    limits: Limits
    counters: Counters
    inline: bool
    blocking: bool
    _inbox: Inbox
    _busy: threading.Lock
    _arrivals: itertools.count[int]
    warn: Callable[..., None]
    key: Callable[[str], str]
    on_priority: Callable[[str, bool, int], None]
    _serve: Callable[[Input], None]
    _on_clock: Callable[[m.Clock], None]
    _other_instance: Callable[[str, bool], None]

    def _put(self, item: Input, size: int = 0, priority: bool = False) -> bool:
        if self._inbox.put(item, size, priority):
            return True
        self.counters.inc("dropped_overflow")
        return False

    def _put_latest(self, item: Input, size: int) -> None:
        """Queue a sample of a `latest` input in place of its topic's one still queued (dropped, counted)."""
        outcome = self._inbox.put_latest(item.suffix, item, size)
        if outcome == "refused":
            self.counters.inc("dropped_overflow")
        elif outcome == "replaced":
            self.counters.inc("dropped_superseded")
            self.warn(f"superseded:{item.suffix}", f"dropped a {item.suffix} sample for a newer one: {self.name} is slower than its input")

    def _take(self, item: Input, size: int, put: Callable[[Input, int], Any]) -> None:
        """A sample from a bus thread: served on that thread if the service is idle and nothing
        older is queued (no thread switch: `inline`), else queued for the worker by `put`
        (`_put`, or `_put_latest` for a `latest` input: chosen once, at subscription)."""
        if self.inline and not self.blocking and self._busy.acquire(blocking=False):
            try:
                if self._inbox.empty():
                    self._serve(item)
                    return
                put(item, size)
            finally:
                self._busy.release()
            return
        put(item, size)

    def _instance_enqueuer(self, mine: str) -> Callable[[str, bool], None]:
        def enqueue(key: str, alive: bool) -> None:
            if key != mine:
                self._put(Input("live", functools.partial(self._other_instance, key.rsplit("/", 1)[-1]), key, bool, alive), priority=True)

        return enqueue

    def _oversize(self, what: str, size: int, limit: int, name: str) -> str:
        """Count and log an input refused for its size (in the bus callback: cheap)."""
        self.counters.inc("oversize")
        text = f"{what}: {size} bytes is over [limits] {name} = {limit}"
        self.warn(f"oversize:{what}", f"dropped {text}")
        return text

    def _enqueue_clock(self, key: str, data: bytes) -> None:
        if len(data) > self.limits.max_payload:
            self._oversize("clock", len(data), self.limits.max_payload, "max_payload")
            return
        self._take(Input("clock", self._on_clock, "clock", m.Clock, data), len(data), self._put)

    def _enqueuer(self, fn: Callable[..., Any], suffix: str, typ: type, latest: bool = False) -> Callable[[str, bytes], None]:
        limit, put = self.limits.max_payload, self._put_latest if latest else self._put

        def enqueue(key: str, data: bytes) -> None:
            if len(data) > limit:
                self._oversize(suffix, len(data), limit, "max_payload")
                return
            self._take(Input("msg", fn, suffix, typ, data), len(data), put)

        return enqueue

    def _token_enqueuer(self, fn: Callable[..., Any]) -> Callable[[str, bool], None]:
        def enqueue(key: str, alive: bool) -> None:
            self._put(Input("live", fn, key, bool, alive), priority=True)

        return enqueue

    def _query_enqueuer(self, fn: Callable[..., Any], suffix: str, typ: type, priority: bool, acts: bool) -> Callable[[Query], None]:
        lim, exact = self.limits, self.key(suffix) if acts else None

        def enqueue(q: Query) -> None:
            arrival = next(self._arrivals)
            size, psize = len(q.payload), q.params_size
            if size > lim.max_payload or psize > lim.max_params:
                big = size > lim.max_payload
                text = self._oversize(
                    f"query {suffix} {'payload' if big else 'parameters'}",
                    size if big else psize,
                    lim.max_payload if big else lim.max_params,
                    "max_payload" if big else "max_params",
                )
                reply_error(q, ErrorCode.INVALID_ARGUMENT, text, read_params=psize <= lim.max_params)
                return
            queued = self._put(Input("query", fn, exact or "", typ, (q, arrival)), size + psize, priority)
            if priority and q.key == exact:
                self.on_priority(suffix, queued, arrival)
            if not queued:
                reply_error(q, ErrorCode.UNAVAILABLE, f"{self.name} is overloaded: input queue full", reason=Reason.OVERLOADED)

        return enqueue
