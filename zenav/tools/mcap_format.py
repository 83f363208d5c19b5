"""The recording format: MCAP files whose messages are JSON with a JSON Schema per message type.

Foxglove decodes the message encodings json, protobuf, ros1, cdr and flatbuffer, not
msgpack. So a recording stores each Zenoh sample decoded through its contract type
(common/keys.py TOPICS) and re-encoded as JSON, on a channel with message encoding
`json` and a `jsonschema` schema generated from the msgspec struct (`zenav.Odom`, one
per type, shared by the channels of every robot). Foxglove's panels and the `mcap`
tools then read the file as it is.

- channel topic: "/" + the Zenoh key (`/zenav/r1/odom`), so that Foxglove message
  paths read `/zenav/r1/odom.x`;
- log_time: the recorder's wall clock when the sample arrived [ns since the epoch]
  (Foxglove's timeline, and the pace of a replay);
- publish_time: the message's `t` on the stack clock [ns].

Replay decodes the JSON through the same type and encodes msgpack again, so what it
publishes is exactly what the contract defines.

A recorder writes `OUT.mcap.part` and renames it to `OUT.mcap` once the file is
finished (footer and summary written). A `.part` file left behind is a recording
whose recorder died (SIGKILL, out of memory, power loss): it has no summary and may
end inside a record. read() reads it sequentially up to its last complete chunk.
"""

from __future__ import annotations

import functools
import json
import os
import struct
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from typing import Any, cast

import msgspec
from mcap.exceptions import McapError
from mcap.reader import NonSeekingReader, make_reader
from mcap.records import Channel, Message
from mcap.well_known import MessageEncoding, SchemaEncoding

from zenav.common import keys
from zenav.common import messages as m

MESSAGE_ENCODING = MessageEncoding.JSON
SCHEMA_ENCODING = SchemaEncoding.JSONSchema
NS = 1_000_000_000  # nanoseconds per second
PART = ".part"  # suffix of a recording not finished (being written, or its recorder died)
MAGIC = b"\x89MCAP0\r\n"  # first and last 8 bytes of a finished MCAP file


class BadRecording(ValueError):
    """A file that is not an MCAP recording, or is damaged before its end."""


def topic_of(key: str) -> str:
    """The MCAP/Foxglove topic of a Zenoh key: `zenav/r1/odom` -> `/zenav/r1/odom`."""
    return "/" + key


def key_of(topic: str) -> str:
    """The Zenoh key of an MCAP/Foxglove topic."""
    return topic.lstrip("/")


def contract_topic(key: str) -> tuple[str, str, type[m.Topic]] | None:
    """(robot, suffix, message type) of a robot's contract topic key; None for any other key."""
    split = keys.split(key)
    if split is None:
        return None
    typ = keys.TOPICS.get(split[1])
    return None if typ is None else (*split, typ)


def schema_name(typ: type) -> str:
    """The schema name of a message type: `zenav.Odom`."""
    return f"zenav.{typ.__name__}"


def _simplify(node: Any, defs: dict[str, Any]) -> Any:
    # Inline `$ref`s and turn Optional[X] (anyOf X, null) into X: Foxglove's JSON Schema
    # reader wants one `type` per field (a string enum gets one). A null value still reads as null.
    if isinstance(node, list):
        return [_simplify(n, defs) for n in node]
    if not isinstance(node, dict):
        return node
    if "$ref" in node:
        return _simplify(defs[node["$ref"].rsplit("/", 1)[-1]], defs)
    options = node.get("anyOf")
    if options is not None:
        not_null = [o for o in options if o != {"type": "null"}]
        if len(not_null) == 1:
            rest = {k: v for k, v in node.items() if k != "anyOf"}
            return {**_simplify(not_null[0], defs), **rest}
    out = {k: _simplify(v, defs) for k, v in node.items()}
    if "enum" in out and "type" not in out and all(isinstance(v, str) for v in out["enum"]):
        out["type"] = "string"  # a Literal of strings: its type too
    return out


def json_schema(typ: type) -> dict[str, Any]:
    """The JSON Schema of a message type, self-contained (no `$ref`)."""
    raw = msgspec.json.schema(typ)
    schema = _simplify(raw, raw.get("$defs", {}))
    schema.pop("$defs", None)
    schema["title"] = schema_name(typ)
    return cast(dict[str, Any], schema)


@functools.cache
def schema_bytes(typ: type) -> bytes:
    """json_schema() as the bytes of an MCAP schema record (computed once per type)."""
    return json.dumps(json_schema(typ)).encode()


def to_json(msg: msgspec.Struct) -> bytes:
    """A message as JSON bytes (the recording's message encoding)."""
    return msgspec.json.encode(msg)


def stamp(t: float) -> int:
    """Seconds -> integer nanoseconds (MCAP times)."""
    return int(round(t * NS))


@dataclass(frozen=True)
class Record:
    """One message read back from a recording."""

    key: str  # Zenoh key it was published on: zenav/<robot>/<suffix>
    robot: str
    suffix: str  # the contract topic
    msg: Any  # the contract message
    log_time: int  # [ns] recorder wall clock at arrival


def finished(path: str) -> bool:
    """Whether a recording was finished (True) or its writer stopped before (False); BadRecording if no MCAP."""
    try:
        with open(path, "rb") as f:
            head = f.read(len(MAGIC))
            size = f.seek(0, os.SEEK_END)
            f.seek(max(size - len(MAGIC), 0))
            tail = f.read()
    except IsADirectoryError:
        raise BadRecording(f"{path}: is a directory") from None
    if head != MAGIC:
        raise BadRecording(f"{path}: not an MCAP file")
    return size > 2 * len(MAGIC) and tail == MAGIC


def _messages(path: str) -> Iterator[tuple[Channel, Message]]:
    # In file order, which is arrival order (the recorder writes as samples arrive).
    # Sequential, so a file with no summary reads too; an unfinished one ends early.
    complete = finished(path)
    with open(path, "rb") as f:
        messages = NonSeekingReader(f).iter_messages(log_time_order=False)
        while True:
            try:
                _, channel, message = next(messages)
            except StopIteration:
                return
            except (McapError, struct.error) as e:
                if complete:
                    raise BadRecording(f"{path}: damaged ({e or type(e).__name__})") from None
                return  # the recorder died while writing this record: the end of what is readable
            yield channel, message


def read(path: str, robot: str | None = None, suffixes: Iterable[str] | None = None) -> Iterator[Record]:
    """The contract messages of a recording in arrival order (optionally one robot, some topics)."""
    wanted = set(suffixes) if suffixes is not None else None
    for channel, message in _messages(path):
        key = key_of(channel.topic)
        topic = contract_topic(key)
        if topic is None or channel.message_encoding != MESSAGE_ENCODING:
            continue
        on, suffix, typ = topic
        if (robot is not None and on != robot) or (wanted is not None and suffix not in wanted):
            continue
        yield Record(key, on, suffix, msgspec.json.decode(message.data, type=typ), message.log_time)


def topics(path: str) -> dict[str, set[str]]:
    """The robot ids that have contract channels in a recording, in first-seen order, each with its topic suffixes.

    An unfinished file has no summary and is read through to find them: kept while the file stays as it was (its
    size and time), so that a replay that checks the robots and then looks for their clocks reads it once."""
    st = os.stat(path)
    return {robot: set(suffixes) for robot, suffixes in _topics(os.path.realpath(path), st.st_size, st.st_mtime_ns).items()}


@functools.lru_cache(maxsize=8)
def _topics(path: str, size: int, mtime_ns: int) -> dict[str, frozenset[str]]:
    """topics() of the file at `path` as it is at that size and time."""
    if finished(path):  # the summary lists every channel
        with open(path, "rb") as f:
            summary = make_reader(f).get_summary()
        channels: Iterable[Channel] = summary.channels.values() if summary else ()
    else:
        channels = (channel for channel, _ in _messages(path))
    found: dict[str, set[str]] = {}
    for channel in channels:
        topic = contract_topic(key_of(channel.topic))
        if topic is not None:
            found.setdefault(topic[0], set()).add(topic[1])
    return {robot: frozenset(suffixes) for robot, suffixes in found.items()}


def robots(path: str) -> list[str]:
    """The robot ids that have contract channels in a recording, in first-seen order."""
    return list(topics(path))
