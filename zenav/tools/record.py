"""Record every contract topic of a robot (or of every robot) to an MCAP file.

The format is tools/mcap_format.py's: JSON messages, one JSON Schema per message
type, channel topic = "/" + Zenoh key. Next to them, the channels the live view shows
(tools/scene.py VIZ_TYPES: poses, map->base_link transform, SceneUpdate, log, in
Foxglove's protobuf schemas, under `/zenav/<robot>/viz/`), so that a recording
opens in Foxglove's 3D panel with the layout of `zenav view`.

Samples go from Zenoh's threads into a queue (tools/tap.py); one writer thread
decodes them and writes the file, so a burst never stalls the session.

Crash safety: the file is written as `OUT.mcap.part` and renamed to `OUT.mcap` once
finished, so an `OUT.mcap` is always complete. Every FLUSH_PERIOD the writer closes
its chunk and hands it to the operating system, so if the process dies (SIGKILL,
out of memory) the `.part` file holds every message received up to at most
FLUSH_PERIOD (plus what was still queued) before, readable by mcap_format.read().
stop() keeps listening for LINGER seconds for samples still on the wire,
unsubscribes, writes what is queued, finishes the file (chunk, indexes, summary)
and renames it, so a Ctrl-C loses nothing that was published before it.
"""

from __future__ import annotations

import os
import time
from collections import Counter
from typing import Any

from mcap.writer import Writer

from zenav.common import codec, keys
from zenav.common.bus import Bus
from zenav.tools import mcap_format as fmt
from zenav.tools.scene import Scene
from zenav.tools.tap import Tap

LINGER = 0.25  # [s] wall time stop() still listens, for samples sent just before it
FLUSH_PERIOD = 1.0  # [s] wall time between two chunks handed to the OS: what a crash loses at most
SCENE_PERIOD = 0.5  # [s] between two recorded SceneUpdates (the live view sends them faster)


class Recorder:
    """Writes `zenav/<robot>/**` (robot None: `zenav/*/**`) to `path` until stop()."""

    def __init__(self, path: str, bus: Bus, robot: str | None = None) -> None:
        self.path = path
        self.part = path + fmt.PART  # the file being written; renamed to `path` when finished
        self.keyexpr = f"{keys.prefix(robot)}/**" if robot else "zenav/*/**"
        self.counts: Counter[str] = Counter()  # key -> contract messages written
        self.skipped: Counter[str] = Counter()  # key -> samples not written (no contract topic, bad payload)
        self._writer = Writer(self.part)
        self._schemas: dict[str, int] = {}  # schema name -> id
        self._channels: dict[str, int] = {}  # topic -> id
        self._scenes: dict[str, Scene] = {}  # robot -> its view
        self._tap = Tap(bus, self.keyexpr, self._write, name="record", tick=self._writer.flush, period=FLUSH_PERIOD)
        self._first_ns: int | None = None
        self._last_ns: int | None = None

    def start(self) -> Recorder:
        """Write the file header and start listening."""
        self._writer.start(profile="", library="zenav")
        self._writer.flush()  # a crash before the first chunk still leaves an MCAP file
        self._tap.start()
        return self

    def stop(self) -> None:
        """Stop listening, write everything received, finish the file and give it its name."""
        time.sleep(LINGER)  # samples published before the stop are still arriving
        self._tap.stop()
        self._writer.finish()
        os.replace(self.part, self.path)

    @property
    def dropped(self) -> int:
        """Samples lost because the writer fell behind (a full queue)."""
        return self._tap.dropped

    @property
    def duration(self) -> float:
        """[s] wall time between the first and the last message written."""
        return (self._last_ns - self._first_ns) / fmt.NS if self._first_ns is not None and self._last_ns is not None else 0.0

    def _channel(self, topic: str, schema_name: str, schema_encoding: str, schema_data: bytes, message_encoding: str) -> int:
        channel = self._channels.get(topic)
        if channel is None:
            schema = self._schemas.get(schema_name)
            if schema is None:
                schema = self._schemas[schema_name] = self._writer.register_schema(schema_name, schema_encoding, schema_data)
            channel = self._channels[topic] = self._writer.register_channel(topic, message_encoding, schema)
        return channel

    def _write(self, key: str, data: bytes, wall_ns: int) -> None:
        topic = fmt.contract_topic(key)
        if topic is None:
            self.skipped[key] += 1
            return
        robot, suffix, typ = topic
        try:
            msg: Any = codec.decode(data, typ)  # a contract message: every one has `t`
        except codec.BadInput:
            self.skipped[key] += 1
            return
        channel = self._channel(fmt.topic_of(key), fmt.schema_name(typ), fmt.SCHEMA_ENCODING, fmt.schema_bytes(typ), fmt.MESSAGE_ENCODING)
        self._writer.add_message(channel, log_time=wall_ns, data=fmt.to_json(msg), publish_time=fmt.stamp(msg.t), sequence=self.counts[key])
        self.counts[key] += 1
        self._first_ns = wall_ns if self._first_ns is None else self._first_ns
        self._last_ns = wall_ns
        scene = self._scenes.get(robot) or self._scenes.setdefault(robot, Scene(robot, SCENE_PERIOD))
        for viz_suffix, viz in scene.feed(suffix, msg, wall_ns):
            self._write_viz(keys.key(robot, viz_suffix), viz, wall_ns)

    def _write_viz(self, key: str, viz: Any, wall_ns: int) -> None:
        schema = viz.get_schema()
        channel = self._channel(fmt.topic_of(key), schema.name, schema.encoding, schema.data, schema.encoding)
        self._writer.add_message(channel, log_time=wall_ns, data=viz.encode(), publish_time=wall_ns)
