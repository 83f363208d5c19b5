"""Serving one input: a sample decoded and handed to its handler, a query answered, a token's change told; what a
handler returns published; whatever fails counted and logged, and the next input served.

A payload that does not decode is counted (`bad_input`), logged and dropped; a bad query gets an
`invalid_argument` reply. A handler that raises is logged and counted (`errors`) and the service keeps going. A
message stamped past the stack clock's horizon is counted (`dropped_future`), logged and dropped: one bad stamp
must not make every later sample look stale (but for an input subscribed `other_clock`: another robot's sim stamps
its body on its own clock, which may be far ahead of this one's).

A query that acts (the default; read-only ones declare `acts=False`) runs only when asked on its exact key: a
wildcard get (`zenav/r1/**`) is answered `invalid_argument` naming the key and counted (`wildcard_refused`).
"""

from __future__ import annotations

import logging
import time
import traceback
from collections.abc import Callable
from typing import Any

from zenav.common import codec
from zenav.common.bus import Query
from zenav.common.clock import Clock
from zenav.common.contract import ErrorCode
from zenav.common.diagnostics import Counters
from zenav.common.intake import Input
from zenav.common.replies import FORMAT_PARAM, QueryError, clip, format_refusal, reply_error, reply_ok


class Dispatch:
    """How a Service serves its inputs (a part of it: the state is the service's)."""

    clock: Clock
    counters: Counters
    _other_clock: set[str]
    _query_arrival: int
    warn: Callable[..., None]
    publish: Callable[[str, Any], None]

    def _dispatch(self, item: Input) -> None:
        """Serve one input. Whatever fails (a handler, or sending what it returned or a reply) is counted (`errors`)
        and logged, and the next input is served: an exception raised here would end the worker, or reach the Zenoh
        thread that serves inline, where only Zenoh would report it."""
        try:
            self._handle(item)
        except Exception as e:
            self.counters.inc("errors")
            what = f"{item.kind} {item.suffix or getattr(item.fn, '__name__', '')}"  # a query acting on no exact key: its handler
            self.warn(f"serve:{what}", f"serving {what} failed: {type(e).__name__}: {clip(str(e))}", logging.ERROR)

    def _handle(self, item: Input) -> None:
        kind, fn, suffix, typ, data = item
        if kind == "query":
            self._dispatch_query(fn, suffix or None, typ, *data)
            return
        if kind == "live":
            try:
                self._publish_result(fn, fn(data))
            except Exception:
                self.counters.inc("errors")
                self.warn(f"live:{fn.__name__}", f"liveliness handler {fn.__name__} failed:\n{traceback.format_exc()}")
            return
        start = time.perf_counter()
        if kind != "clock":
            self.counters.inc("msgs_in")
            self.counters.seen(suffix)
        else:
            self.counters.inc("clock_ticks")  # taken like any message (the transport's cost), not input of the service's
        try:
            msg: Any = codec.decode(data, typ)
        except codec.BadInput as e:
            self.counters.inc("bad_input")
            self.warn(f"bad:{suffix}", f"dropped bad input on {suffix}: {e}")
            return
        t = getattr(msg, "t", None)
        if t is not None and kind != "clock" and not self.clock.admits(t) and suffix not in self._other_clock:
            self.counters.inc("dropped_future")
            self.warn(f"future:{suffix}", f"dropped {suffix} stamped t={t:.3f}, {t - self.clock.now():.3f} s ahead of the clock")
            return
        try:
            out = fn(msg)
        except Exception:
            self.counters.inc("errors")
            self.warn(f"err:{suffix}", f"handler for {suffix} failed:\n{traceback.format_exc()}")
            return
        self._publish_result(fn, out)
        if kind != "clock":
            self.counters.served(suffix, time.perf_counter() - start)

    def _publish_result(self, fn: Callable[..., Any], out: Any) -> None:
        target = getattr(fn, "_zenav_pub", None)
        if target is not None and out is not None:
            self.publish(target, out)

    def _dispatch_query(self, fn: Callable[..., Any], exact: str | None, typ: type, q: Query, arrival: int) -> None:
        self.counters.inc("queries")
        if exact is not None and q.key != exact:
            self.counters.inc("wildcard_refused")
            self.warn("wildcard", f"refused a query on {q.key}: it acts, so only {exact} is served")
            reply_error(q, ErrorCode.INVALID_ARGUMENT, f"{q.key}: this query acts; ask it on its exact key {exact}")
            return
        refused = format_refusal(q.params.get(FORMAT_PARAM) if q.params_size else None)
        if refused is not None:
            self.counters.inc("bad_input")
            reply_error(q, ErrorCode.INVALID_ARGUMENT, refused)
            return
        try:
            params = {k: v for k, v in q.params.items() if not k.startswith("_")} if q.params_size else {}
            req: Any = codec.decode(q.payload, typ) if q.payload else codec.from_params(params, typ)
        except codec.BadInput as e:
            self.counters.inc("bad_input")
            self.warn(f"badq:{fn.__name__}", f"bad query on {q.key}: {e}")
            reply_error(q, ErrorCode.INVALID_ARGUMENT, clip(str(e)))
            return
        self._query_arrival = arrival
        try:
            rep = fn(req, q)
        except QueryError as e:
            if e.code == ErrorCode.INVALID_ARGUMENT:
                self.counters.inc("bad_input")
            reply_error(q, e.code, e.message, reason=e.reason)
            return
        except Exception as e:
            self.counters.inc("errors")
            self.warn(f"query:{fn.__name__}", f"query {q.key} failed:\n{traceback.format_exc()}", logging.ERROR)
            reply_error(q, ErrorCode.INTERNAL, clip(f"{type(e).__name__}: {e}"))
            return
        finally:
            self._query_arrival = 0
        if rep is not None:
            reply_ok(q, rep)

    def _fire(self, fn: Callable[[float], Any], now: float) -> None:
        """Run a timer or a call at `now`, publishing what it returns (@publish); a failure is logged and counted."""
        try:
            self._publish_result(fn, fn(now))
        except Exception:
            self.counters.inc("errors")
            self.warn(f"timer:{fn.__name__}", f"timer {fn.__name__} failed:\n{traceback.format_exc()}")
