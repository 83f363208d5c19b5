"""A recording holds the channels `zenav view` serves: the contract topics and the 3D panel's scene and transforms."""

from __future__ import annotations

import math
import threading

from mcap.reader import make_reader

from zenav.common import codec, keys
from zenav.common import messages as m
from zenav.common.bus import MemoryBus, ZenohBus
from zenav.tools.record import SCENE_PERIOD, Recorder
from zenav.tools.scene import VIZ_TYPES
from zenav.tools.view import View

STEPS = 150  # messages per topic: 1.5 s of a robot at 100 Hz


def drive(bus: ZenohBus, done: threading.Event) -> None:
    """A robot on a circle, with fixes, a goal and a rejected fix, published at 100 Hz."""
    pace = threading.Event()  # never set: its wait() paces the synthetic robot
    goal = {"type": "move_to_point", "x": 1.0, "y": 1.0}
    cov = (1e-3, 0.0, 0.0, 0.0, 1e-3, 0.0, 0.0, 0.0, 1e-3)
    for i in range(STEPS):
        t = i * 0.01
        x, y = math.sin(t), 1.0 - math.cos(t)
        bus.publish(keys.key("r1", "sim/truth"), codec.encode(m.Truth(t=t, x=x, y=y, theta=t, v=0.1, omega=0.1)))
        bus.publish(keys.key("r1", "odom"), codec.encode(m.Odom(t=t, x=x, y=y, theta=t, v=0.1, omega=0.1)))
        bus.publish(keys.key("r1", "pose"), codec.encode(m.Pose(t=t, x=x, y=y, theta=t, v=0.1, omega=0.1, cov=cov)))
        if i % 20 == 0:
            bus.publish(keys.key("r1", "vps/pose"), codec.encode(m.VpsPose(t=t, x=x, y=y, theta=t, cov=cov)))
            fix = m.Fix(
                t=t,
                t_arrival=t,
                latency=0.0,
                replay_depth=0,
                innovation=(0.0, 0.0, 0.0),
                mahalanobis_d2=50.0,
                accepted=False,
                reason="gate",
            )
            bus.publish(keys.key("r1", "localizer/fixes"), codec.encode(fix))
            bus.publish(keys.key("r1", "nav/state"), codec.encode(m.NavState(t=t, state="MOVING", goal_id=1, goal=goal)))
        pace.wait(0.01)
    done.set()


def test_a_recording_has_the_channels_and_schemas_of_the_live_view(router, tmp_path):
    path = tmp_path / "run.mcap"
    publisher, rec_bus = ZenohBus.open(router), ZenohBus.open(router)
    rec = Recorder(str(path), rec_bus, "r1").start()
    done = threading.Event()
    try:
        drive(publisher, done)
    finally:
        rec.stop()
        rec_bus.close()
        publisher.close()
    assert done.is_set() and rec.counts[keys.key("r1", "pose")] > 0

    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None
        recorded = {
            c.topic: (summary.schemas[c.schema_id].name, summary.schemas[c.schema_id].encoding, c.message_encoding)
            for c in summary.channels.values()
        }
        counts = {summary.channels[i].topic: n for i, n in summary.statistics.channel_message_counts.items()}
        viz = {c.topic: (s, msg) for s, c, msg in reader.iter_messages(topics=[f"/zenav/r1/{v}" for v in VIZ_TYPES])}

    view = View(MemoryBus(), "r1", port=0)
    try:
        served = view.channels()
    finally:
        view.stop()
    # every channel recorded is one the live view serves, under the same topic and schema
    assert {t: served[t] for t in recorded} == recorded
    # all of the 3D panel's: poses, the map->base_link transform, the scene, the log
    assert {f"/zenav/r1/{v}" for v in VIZ_TYPES} <= set(recorded)
    for topic, (schema, message) in viz.items():
        assert schema.data == VIZ_TYPES[topic.split("/", 3)[3]].get_schema().data and len(message.data) > 0
    # a SceneUpdate every SCENE_PERIOD of the recording's 1.5 s, not one per message
    assert 2 <= counts["/zenav/r1/viz/scene"] <= STEPS * 0.01 / SCENE_PERIOD + 2
    assert counts["/zenav/r1/viz/tf"] == counts["/zenav/r1/pose"]
