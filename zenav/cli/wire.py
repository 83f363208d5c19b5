"""What the introspection commands show of the wire: keys, payloads as JSON, rates (pure: no session, no clock)."""

from __future__ import annotations

import difflib
import json
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import msgspec
import zenoh

from zenav.common import codec, keys
from zenav.common import messages as m
from zenav.common.client import foreign_error

ABSOLUTE = ("zenav/", "@/")  # keys typed with these prefixes are taken as they are


def resolve(robot: str, key: str) -> str:
    """A key as typed -> its key expression: `pose` -> zenav/<robot>/pose, a field topic (`sim/body`) ->
    zenav/field/sim/body, `zenav/...` and `@/...` as they are.

    ValueError if it is not a valid Zenoh key expression.
    """
    if key.startswith(ABSOLUTE):
        full = key
    else:
        full = keys.field_key(key) if key in keys.FIELD_TOPICS else f"{keys.prefix(robot)}/{key}"
    try:
        zenoh.KeyExpr(full)
    except zenoh.ZError:
        raise ValueError(f"{key!r} is not a key expression (e.g. pose, 'diag/*', zenav/r1/odom)") from None
    return full


def topic_type(full: str) -> type | None:
    """The contract's message type of a topic key; None if the contract has none for it."""
    where = keys.split(full)
    if where is None:
        return None
    return keys.FIELD_TOPICS.get(where[1]) if where[0] == keys.FIELD else keys.TOPICS.get(where[1])


TOKENS = ("alive/", "instance/", "lease/")  # a robot's liveliness tokens: no samples come on them


def unknown_topic(full: str) -> str | None:
    """A note for a key without wildcards that names no contract topic under zenav/ (a typo? a token or a
    query, which send no samples?), with the nearest name; else None."""
    where = keys.split(full)
    if where is None or "*" in full or topic_type(full) is not None:
        return None
    if where[1].startswith(TOKENS):
        return f"{where[1]} is a liveliness token, which sends no messages: `zenav topics` lists the tokens; listening anyway"
    if where[1] in keys.QUERIES:
        return f"{where[1]} is a query, which sends no messages: `zenav query {where[1]}`; listening anyway"
    names = keys.FIELD_TOPICS if where[0] == keys.FIELD else keys.TOPICS
    near = difflib.get_close_matches(where[1], names, n=1)
    return f"{where[1]} is no topic of the contract{f' (did you mean {near[0]}?)' if near else ''}; listening anyway"


def query_types(full: str) -> tuple[type, type] | None:
    """(request type, reply type) of a contract query key; None for other keys."""
    where = keys.split(full)
    return None if where is None or where[0] == keys.FIELD else keys.QUERIES.get(where[1])


def decode(data: bytes, typ: type | None = None) -> tuple[str, Any]:
    """(kind, value) of a payload: its contract type's name and fields when it is one, else
    `msgpack`, `json` or `text` and the value, else `bytes` and the payload's size."""
    if typ is not None:
        try:
            return typ.__name__, msgspec.to_builtins(codec.decode(data, typ))
        except codec.BadInput:
            pass
    for kind, parse in (("msgpack", msgspec.msgpack.decode), ("json", json.loads)):
        try:
            return kind, msgspec.to_builtins(parse(data))
        except (ValueError, TypeError, RecursionError):  # msgspec.DecodeError is a ValueError
            pass
    try:
        return "text", data.decode()
    except UnicodeDecodeError:
        return "bytes", len(data)


def json_line(key: str, data: bytes, typ: type | None = None) -> str:
    """One sample as one JSON object: {"key": ..., "type": ..., "msg": ...} (bytes as base64, NaN as null)."""
    kind, value = decode(data, typ)
    return msgspec.json.encode({"key": key, "type": kind, "msg": value}).decode()


def error_reply(data: bytes) -> tuple[str, str]:
    """(code, message) of an error reply: the contract's ErrorReply, or Zenoh's own text."""
    try:
        err = codec.decode(data, m.ErrorReply)
    except codec.BadInput:
        return foreign_error(data), data.decode(errors="replace")
    return err.error, err.message


def parse_params(items: Sequence[str]) -> dict[str, Any]:
    """`["x=1", "y=-0.5", "name=r1", "points=[[0,0]]"]` -> request fields: values parsed as JSON where they parse, else strings.

    ValueError for an item that is not KEY=VALUE.
    """
    out: dict[str, Any] = {}
    for item in items:
        name, sep, text = item.partition("=")
        if not (sep and name):
            raise ValueError(f"{item!r} is not KEY=VALUE (e.g. x=1.5, name=r1, points=[[0,0],[1,0]])")
        try:
            out[name] = json.loads(text)
        except ValueError:
            out[name] = text
    return out


@dataclass(frozen=True)
class Rate:
    """Arrivals of one key: how many, their rate and the spread of their periods."""

    count: int
    hz: float | None  # [Hz] (count - 1) / span; None under two arrivals
    min: float | None  # [s] shortest period
    max: float | None  # [s] longest period
    std: float | None  # [s] standard deviation of the periods


def rate(times: Iterable[float]) -> Rate:
    """The Rate of arrival times [s], in order."""
    ts = list(times)
    periods = [b - a for a, b in zip(ts, ts[1:], strict=False)]
    if not periods:
        return Rate(len(ts), None, None, None, None)
    mean = sum(periods) / len(periods)
    std = math.sqrt(sum((p - mean) ** 2 for p in periods) / len(periods))
    hz = 1.0 / mean if mean > 0 else math.inf
    return Rate(len(ts), hz, min(periods), max(periods), std)


def hz_line(key: str, r: Rate) -> str:
    """One line of `zenav hz`, as `ros2 topic hz` gives it."""
    if r.hz is None:
        return f"{key}: {r.count} message{'s' if r.count != 1 else ''}, no rate yet"
    return f"{key}: average rate {r.hz:.3f} Hz  min {r.min:.4f} s  max {r.max:.4f} s  std dev {r.std:.5f} s  window {r.count}"


@dataclass(frozen=True)
class Seen:
    """What `zenav topics` saw of one key during its window."""

    key: str
    kind: str  # message type (contract name, msgpack, json, text, bytes)
    rate: Rate
    size: float  # [bytes] mean payload


def topics_table(seen: Sequence[Seen], tokens: Sequence[str], window: float) -> str:
    """The `zenav topics` listing: one row per key with samples, then the liveliness tokens."""
    lines = [f"{len(seen)} key{'s' if len(seen) != 1 else ''} with publishers in {window:g} s"]
    if seen:
        width = max(len(s.key) for s in seen)
        lines.append(f"{'KEY':<{width}}  {'TYPE':<12} {'RATE':>10} {'MSGS':>6} {'BYTES':>8}")
        for s in sorted(seen, key=lambda s: s.key):
            hz = "-" if s.rate.hz is None else f"{s.rate.hz:.1f} Hz"
            lines.append(f"{s.key:<{width}}  {s.kind:<12} {hz:>10} {s.rate.count:>6} {s.size:>8.0f}")
    lines.append(f"{len(tokens)} liveliness token{'s' if len(tokens) != 1 else ''}")
    lines += [f"  {t}" for t in sorted(tokens)]
    return "\n".join(lines)
