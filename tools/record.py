"""Record every contract topic of a robot (or of every robot) to an MCAP file.

The format is tools/mcap_format.py's: JSON messages, one JSON Schema per message
type, channel topic = "/" + Zenoh key. Samples go from Zenoh's threads into a queue
(tools/tap.py); one writer thread decodes them and writes the file, so a burst never
stalls the session. stop() keeps listening for LINGER seconds for samples still on
the wire, unsubscribes, writes what is queued, and finishes the file (chunk, indexes,
summary), so a Ctrl-C loses nothing that was published before it.
"""
from __future__ import annotations

import time
from collections import Counter
from typing import Optional

from mcap.writer import Writer

from zenav.common import codec, keys
from zenav.common.bus import Bus
from zenav.tools import mcap_format as fmt
from zenav.tools.tap import Tap

LINGER = 0.25  # [s] wall time stop() still listens, for samples sent just before it


class Recorder:
    """Writes `zenav/<robot>/**` (robot None: `zenav/*/**`) to `path` until stop()."""

    def __init__(self, path: str, bus: Bus, robot: Optional[str] = None) -> None:
        self.path = path
        self.keyexpr = f"{keys.prefix(robot)}/**" if robot else "zenav/*/**"
        self.counts: Counter[str] = Counter()  # key -> messages written
        self.skipped: Counter[str] = Counter()  # key -> samples not written (no contract topic, bad payload)
        self._writer = Writer(path)
        self._schemas: dict[type, int] = {}
        self._channels: dict[str, int] = {}
        self._tap = Tap(bus, self.keyexpr, self._write, name="record")
        self._first_ns: Optional[int] = None
        self._last_ns: Optional[int] = None

    def start(self) -> Recorder:
        """Write the file header and start listening."""
        self._writer.start(profile="", library="zenav")
        self._tap.start()
        return self

    def stop(self) -> None:
        """Stop listening, write everything received, finish the file."""
        time.sleep(LINGER)  # samples published before the stop are still arriving
        self._tap.stop()
        self._writer.finish()

    @property
    def dropped(self) -> int:
        """Samples lost because the writer fell behind (a full queue)."""
        return self._tap.dropped

    @property
    def duration(self) -> float:
        """[s] wall time between the first and the last message written."""
        return (self._last_ns - self._first_ns) / fmt.NS if self._first_ns is not None else 0.0

    def _channel(self, key: str, typ: type) -> int:
        channel = self._channels.get(key)
        if channel is None:
            schema = self._schemas.get(typ)
            if schema is None:
                schema = self._schemas[typ] = self._writer.register_schema(
                    fmt.schema_name(typ), fmt.SCHEMA_ENCODING, fmt.schema_bytes(typ)
                )
            channel = self._channels[key] = self._writer.register_channel(fmt.topic_of(key), fmt.MESSAGE_ENCODING, schema)
        return channel

    def _write(self, key: str, data: bytes, wall_ns: int) -> None:
        typ = fmt.message_type(key)
        if typ is None:
            self.skipped[key] += 1
            return
        try:
            msg = codec.decode(data, typ)
        except codec.BadInput:
            self.skipped[key] += 1
            return
        self._writer.add_message(
            self._channel(key, typ),
            log_time=wall_ns,
            data=fmt.to_json(msg),
            publish_time=fmt.stamp(msg.t),
            sequence=self.counts[key],
        )
        self.counts[key] += 1
        self._first_ns = wall_ns if self._first_ns is None else self._first_ns
        self._last_ns = wall_ns
