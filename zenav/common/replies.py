"""Query replies: msgpack or JSON (`_format=json`), the contract's error map, and clipped log text.

Replies are msgpack, or JSON text (Zenoh encoding application/json) when the query asks with the selector
parameter `_format=json` (browsers and curl through Zenoh's REST plugin). Parameters named `_...` are Zenoh's
(`_format`, the REST plugin's `_raw`, `_time`), never request fields.

Log lines that may carry what a sender sent (decode errors, tracebacks, keys) are cut to LOG_CHARS characters a
line (`clip`).
"""

from __future__ import annotations

from typing import Any

import msgspec

from zenav.common import codec
from zenav.common import messages as m
from zenav.common.bus import JSON, MSGPACK, Query

LOG_CHARS = 200  # a log line (and an internal error reply) is cut to this many characters
FORMAT_PARAM = "_format"  # selector parameter choosing the reply format: msgpack (default) or json
FORMATS = {"msgpack": MSGPACK, "json": JSON}


def clip(text: str, limit: int = LOG_CHARS) -> str:
    """`text` with each line cut to `limit` characters (a payload's repr must not flood the log)."""
    return "\n".join(
        line if len(line) <= limit else f"{line[:limit]}... ({len(line) - limit} more characters)" for line in text.split("\n")
    )


class QueryError(Exception):
    """Raised by a query handler to answer with an error reply."""

    def __init__(self, code: str, message: str, reason: str = "") -> None:
        super().__init__(message)
        self.code, self.message, self.reason = code, message, reason


def format_refusal(fmt: str | None) -> str | None:
    """Why a query's reply format (its `_format` parameter, None: not given) cannot be served; None if it can."""
    if fmt is None or fmt in FORMATS:
        return None
    return f"{FORMAT_PARAM}={clip(fmt, 40)}: expected one of {', '.join(FORMATS)}"


def reply_format(q: Query) -> str:
    """The encoding a query asked its replies in (`_format=json`: JSON; otherwise msgpack)."""
    if not q.params_size:
        return MSGPACK
    return FORMATS.get(q.params.get(FORMAT_PARAM, "msgpack"), MSGPACK)


def _encode(msg: Any, encoding: str) -> bytes:
    return msgspec.json.encode(msg) if encoding == JSON else codec.encode(msg)


def reply_error(q: Query, code: str, message: str, *, reason: str = "", read_params: bool = True) -> None:
    """Answer a query with the contract's error map (`reason`: a contract.Reason, or ""), and end it.

    `read_params=False`: msgpack without parsing the selector parameters (refused as oversize)."""
    encoding = reply_format(q) if read_params else MSGPACK
    q.reply_err(_encode(m.ErrorReply(error=code, message=message, reason=reason), encoding), encoding)
    q.finish()


def reply_ok(q: Query, reply: m.Reply) -> None:
    """Answer a query with a reply message, and end it."""
    encoding = reply_format(q)
    q.reply(_encode(reply, encoding), encoding)
    q.finish()
