"""A live view of one robot in the Foxglove app, through the foxglove-sdk WebSocket server.

Two kinds of channels:
- every contract topic, mirrored as it is on the wire: JSON with the recording's JSON
  Schema, on the recording's topic names (`/zenav/r1/odom`), so that one layout
  (zenav/data/foxglove-layout.json) plots the same fields live and from an MCAP file;
- what a 3D panel draws (tools/scene.py), in Foxglove's own schemas under
  `/zenav/<robot>/viz/`: `truth`, `odom`, `pose` (PoseInFrame), `tf` (map ->
  base_link), `scene` (SceneUpdate: trails, covariance ellipse, VPS fixes, goal and
  path, navigator state; sent every scene.SCENE_PERIOD) and `log` (navigator events,
  rejected fixes, status changes). `zenav record` writes the same channels.
"""

from __future__ import annotations

from typing import Any

import foxglove
from foxglove import channels as fc

from zenav.common import codec, keys
from zenav.common.bus import Bus
from zenav.tools import mcap_format as fmt
from zenav.tools.scene import Scene
from zenav.tools.tap import Tap

DEFAULT_HOST = "127.0.0.1"  # loopback: the view shows ground truth and needs no wider audience
DEFAULT_PORT = 8765  # Foxglove's usual WebSocket port


VIZ_CHANNELS = {  # view topic suffix -> Foxglove channel type
    "viz/truth": fc.PoseInFrameChannel,
    "viz/odom": fc.PoseInFrameChannel,
    "viz/pose": fc.PoseInFrameChannel,
    "viz/tf": fc.FrameTransformsChannel,
    "viz/scene": fc.SceneUpdateChannel,
    "viz/log": fc.LogChannel,
}


class View:
    """Serve one robot's topics and scene to Foxglove clients until stop()."""

    def __init__(self, bus: Bus, robot: str = "r1", host: str = DEFAULT_HOST, port: int = DEFAULT_PORT) -> None:
        self.robot = keys.check_robot_id(robot)
        self.context = foxglove.Context()
        # Every channel exists before the first client connects: clients see the
        # whole topic list at once, and none is advertised while one is connecting.
        self._mirrors = {suffix: self._mirror(suffix, typ) for suffix, typ in keys.TOPICS.items()}
        self._viz: dict[str, Any] = {suffix: cls(self._topic(suffix), context=self.context) for suffix, cls in VIZ_CHANNELS.items()}
        self.server = foxglove.start_server(name=f"zenav {robot}", host=host, port=port, context=self.context)
        self.scene = Scene(robot)
        self._tap = Tap(bus, f"{keys.prefix(robot)}/**", self._on_sample, name="view")

    @property
    def port(self) -> int:
        """The port the server listens on (useful when started on port 0)."""
        return self.server.port

    def start(self) -> View:
        """Start following the robot's topics."""
        self._tap.start()
        return self

    def stop(self) -> None:
        """Stop following and close the server."""
        self._tap.stop()
        self.server.stop()

    def channels(self) -> dict[str, tuple[str, str, str]]:
        """Every channel served: topic -> (schema name, schema encoding, message encoding)."""
        out = {}
        served: list[Any] = [*self._mirrors.values(), *self._viz.values()]
        for ch in served:
            schema = ch.schema()
            out[ch.topic()] = (schema.name, schema.encoding, ch.message_encoding)
        return out

    def app_url(self) -> str | None:
        """A Foxglove web app address that opens this server as its data source."""
        return self.server.app_url()

    def _topic(self, suffix: str) -> str:
        return fmt.topic_of(keys.key(self.robot, suffix))

    def _mirror(self, suffix: str, typ: type) -> foxglove.Channel:
        schema = foxglove.Schema(name=fmt.schema_name(typ), encoding=fmt.SCHEMA_ENCODING, data=fmt.schema_bytes(typ))
        return foxglove.Channel(self._topic(suffix), schema=schema, message_encoding=fmt.MESSAGE_ENCODING, context=self.context)

    def _on_sample(self, key: str, data: bytes, ns: int) -> None:
        topic = fmt.contract_topic(key)
        if topic is None:
            return
        _, suffix, typ = topic
        try:
            msg: Any = codec.decode(data, typ)  # a contract message: every one has `t`
        except codec.BadInput:
            return
        self._mirrors[suffix].log(fmt.to_json(msg), log_time=ns)
        for viz_suffix, viz in self.scene.feed(suffix, msg, ns):
            self._viz[viz_suffix].log(viz, log_time=ns)
