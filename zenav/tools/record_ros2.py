"""Record one robot as a ROS 2 bag (rosbag2's MCAP storage): what `ros2 bag play` replays.

The bag is a directory: `metadata.yaml` (rosbag2 metadata version 8: topics, types,
serialization `cdr`, the RIHS01 type hashes, counts, times) and `<name>.mcap`, whose
channels carry CDR messages (message encoding `cdr`) with `ros2msg` schemas (the .msg
text and its dependencies), written by rosbags' rosbag2 writer. The topics and messages
are those `zenav ros2` publishes (tools/ros2_out.py: /odom, /odometry, /pose, /tf,
/nav/state, /map) and /cmd_vel (geometry_msgs/Twist, what the navigator or a teleop commanded),
stamped in wall time; a message's log time is the recorder's wall clock when the zenav
sample arrived. /map is recorded with a transient local QoS (reliable, keep last 1), so
`ros2 bag play` republishes it latched, as a map server does.

metadata.yaml is written when the recording stops; a recorder that dies leaves the
.mcap without it (`ros2 bag reindex DIR` writes it from the .mcap).
"""

from __future__ import annotations

import time
from collections import Counter
from typing import Any, Literal

from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
from rosbags.rosbag2 import StoragePlugin, Writer

from zenav.common import codec, keys
from zenav.common.bus import Bus
from zenav.tools import ros2_out as ro
from zenav.tools.rmw_zenoh import Wire
from zenav.tools.tap import Tap

LINGER = 0.25  # [s] wall time stop() still listens, for samples sent just before it
TOPICS = (*ro.BRIDGED, ro.CMD_VEL)
VERSION: Literal[8] = 8  # rosbag2 metadata version (Iron, Jazzy; Kilted reads it too)
_NEVER = QosTime(sec=0x7FFFFFFF, nsec=0xFFFFFFFF)  # rmw's "infinite" duration, as rosbag2 writes it
LATCHED_QOS = Qos(  # a map server's: keep last 1, reliable, transient local
    QosHistory.KEEP_LAST, 1, QosReliability.RELIABLE, QosDurability.TRANSIENT_LOCAL, _NEVER, _NEVER, QosLiveliness.AUTOMATIC, _NEVER, False
)


class Ros2Recorder:
    """Writes `zenav/<robot>/**` as ROS 2 messages into the bag directory `path` until stop()."""

    def __init__(self, path: str, bus: Bus, robot: str, distro: str) -> None:
        self.path, self.robot = path, robot
        self.keyexpr = f"{keys.prefix(robot)}/**"
        self.wire = Wire(distro=distro)
        self.converter = ro.Converter(self.wire.types(), TOPICS)
        self.counts: Counter[str] = Counter()  # ROS topic -> messages written
        self.skipped = 0  # samples not converted: bad payloads
        self._writer = Writer(path, version=VERSION, storage_plugin=StoragePlugin.MCAP)
        self._connections: dict[str, Any] = {}
        self._tap = Tap(bus, self.keyexpr, self._write, name="record-ros2")
        self._first_ns: int | None = None
        self._last_ns: int | None = None

    def start(self) -> Ros2Recorder:
        """Create the bag and start listening."""
        self._writer.open()
        self._tap.start()
        return self

    def stop(self) -> None:
        """Stop listening, write everything received and the bag's metadata.yaml."""
        time.sleep(LINGER)  # samples published before the stop are still arriving
        self._tap.stop()
        self._writer.close()

    @property
    def dropped(self) -> int:
        """Samples lost because the writer fell behind (a full queue)."""
        return self._tap.dropped

    @property
    def duration(self) -> float:
        """[s] wall time between the first and the last message written."""
        return (self._last_ns - self._first_ns) / 1e9 if self._first_ns is not None and self._last_ns is not None else 0.0

    def _write(self, key: str, data: bytes, wall_ns: int) -> None:
        split = keys.split(key)
        if split is None or split[1] not in ro.SUFFIXES:
            return
        try:
            msg = codec.decode(data, keys.TOPICS[split[1]])
        except codec.BadInput:
            self.skipped += 1
            return
        for name, ros in self.converter.feed(msg):
            topic = "/" + name.lstrip("/")
            ros_type = ro.TYPES[name][0]
            conn = self._connections.get(topic)
            if conn is None:
                qos = (LATCHED_QOS,) if name in ro.LATCHED else ()
                conn = self._writer.add_connection(topic, ros_type, typestore=self.wire.store, offered_qos_profiles=qos)
                self._connections[topic] = conn
            self._writer.write(conn, wall_ns, self.wire.serialize(ros, ros_type))
            self.counts[topic] += 1
            self._first_ns = wall_ns if self._first_ns is None else self._first_ns
            self._last_ns = wall_ns
