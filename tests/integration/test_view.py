"""`zenav view`: a Foxglove WebSocket client receives the robot live (advertise -> subscribe -> message frames)."""

from __future__ import annotations

import json
import math
import signal
import struct
import subprocess
import sys
import threading
import time

import pytest
from websockets.sync.client import connect

from tests.support.procs import reaped, stderr_lines
from zenav.common import codec, keys
from zenav.common import messages as m
from zenav.common.bus import ZenohBus
from zenav.stack.inprocess import free_port
from zenav.tools.view import View

SUBPROTOCOLS = ["foxglove.sdk.v1", "foxglove.websocket.v1"]  # the SDK's current name, and the older one
MESSAGE_DATA = 0x01  # binary opcode: subscription id (u32), receive time (u64), payload


def publish_run(bus: ZenohBus, stop: threading.Event) -> None:
    """A robot driving a circle: truth, odom, fused pose, VPS fixes and the navigator's state, until `stop`."""
    goal = {"type": "follow_path", "points": [[1.0, 0.0], [1.0, 1.0]]}
    i = 0
    while not stop.wait(0.01) and i < 3000:  # pacing the synthetic robot at 100 Hz, 30 s at most
        t, th = i * 0.01, i * 0.01
        x, y = math.sin(th), 1.0 - math.cos(th)
        cov = (1e-3, 2e-4, 0.0, 2e-4, 4e-4, 0.0, 0.0, 0.0, 1e-3)
        bus.publish(keys.key("r1", "sim/truth"), codec.encode(m.Truth(t=t, x=x, y=y, theta=th, v=0.1, omega=0.1)))
        bus.publish(keys.key("r1", "odom"), codec.encode(m.Odom(t=t, x=x * 1.02, y=y, theta=th, v=0.1, omega=0.1)))
        bus.publish(keys.key("r1", "pose"), codec.encode(m.Pose(t=t, x=x, y=y + 0.01, theta=th, v=0.1, omega=0.1, cov=cov)))
        if i % 10 == 0:
            bus.publish(keys.key("r1", "vps/pose"), codec.encode(m.VpsPose(t=t, x=x + 0.02, y=y, theta=th, cov=cov)))
            state = m.NavState(t=t, state="FOLLOWING_PATH", goal_id=1, goal=goal, distance_remaining=1.0, next_point=0)
            bus.publish(keys.key("r1", "nav/state"), codec.encode(state))
        i += 1


@pytest.fixture
def view(router):
    bus = ZenohBus.open(router)
    v = View(bus, "r1", port=0).start()  # port 0: any free port
    yield v
    v.stop()
    bus.close()


@pytest.fixture
def robot(router):
    bus = ZenohBus.open(router)
    stop = threading.Event()
    th = threading.Thread(target=publish_run, args=(bus, stop), daemon=True)
    th.start()
    yield
    stop.set()
    th.join(10)
    bus.close()


def receive(port: int, topics: set[str], timeout: float = 30.0) -> tuple[dict[str, dict], dict[str, list[bytes]]]:
    """Subscribe to `topics` as Foxglove does; return their advertisements and first payloads."""
    channels: dict[str, dict] = {}
    payloads: dict[str, list[bytes]] = {}
    subs: dict[int, str] = {}
    deadline = time.monotonic() + timeout
    with connect(f"ws://127.0.0.1:{port}", subprotocols=SUBPROTOCOLS, open_timeout=10) as ws:
        assert ws.subprotocol in SUBPROTOCOLS
        while not all(len(payloads.get(t, ())) >= 3 for t in topics):
            left = deadline - time.monotonic()
            assert left > 0, f"no messages in {timeout} s on {sorted(t for t in topics if t not in payloads)}"
            frame = ws.recv(timeout=left)
            if isinstance(frame, str):
                op = json.loads(frame)
                if op["op"] != "advertise":
                    continue
                subscriptions = []
                for c in op["channels"]:
                    if c["topic"] in topics and c["topic"] not in channels:
                        channels[c["topic"]] = c
                        subs[len(subs) + 1] = c["topic"]
                        subscriptions.append({"id": len(subs), "channelId": c["id"]})
                if subscriptions:
                    ws.send(json.dumps({"op": "subscribe", "subscriptions": subscriptions}))
            elif frame[0] == MESSAGE_DATA:
                sub_id, _receive_ns = struct.unpack_from("<IQ", frame, 1)
                payloads.setdefault(subs[sub_id], []).append(frame[13:])
    return channels, payloads


def test_a_foxglove_client_receives_the_robot_live(view, robot):
    wanted = {
        "/zenav/r1/pose",
        "/zenav/r1/nav/state",
        "/zenav/r1/viz/truth",
        "/zenav/r1/viz/odom",
        "/zenav/r1/viz/pose",
        "/zenav/r1/viz/tf",
        "/zenav/r1/viz/scene",
    }
    channels, payloads = receive(view.port, wanted)
    # the wire topics, mirrored as JSON with their schema
    assert channels["/zenav/r1/pose"]["encoding"] == "json"
    assert channels["/zenav/r1/pose"]["schemaName"] == "zenav.Pose"
    assert "properties" in json.loads(channels["/zenav/r1/pose"]["schema"])
    pose = json.loads(payloads["/zenav/r1/pose"][-1])
    assert pose["frame"] == "map" and len(pose["cov"]) == 9
    assert abs(pose["y"] - (1.0 - math.cos(pose["theta"])) - 0.01) < 1e-9
    assert json.loads(payloads["/zenav/r1/nav/state"][-1])["state"] == "FOLLOWING_PATH"
    # what the 3D panel draws, in Foxglove's schemas
    expected = {
        "/zenav/r1/viz/truth": "foxglove.PoseInFrame",
        "/zenav/r1/viz/odom": "foxglove.PoseInFrame",
        "/zenav/r1/viz/pose": "foxglove.PoseInFrame",
        "/zenav/r1/viz/tf": "foxglove.FrameTransforms",
        "/zenav/r1/viz/scene": "foxglove.SceneUpdate",
    }
    for topic, schema in expected.items():
        assert (channels[topic]["encoding"], channels[topic]["schemaName"]) == ("protobuf", schema)
        assert all(len(p) > 0 for p in payloads[topic])


def test_the_view_command_serves_until_ctrl_c(router, robot):
    port = free_port()
    proc = subprocess.Popen(
        [sys.executable, "-m", "zenav", "view", "--connect", router, "--port", str(port)], stderr=subprocess.PIPE, text=True
    )
    lines = stderr_lines(proc)
    with reaped(proc):
        assert f"zenav view of robot r1 on ws://127.0.0.1:{port}" in lines.get(timeout=30)
        _, payloads = receive(port, {"/zenav/r1/viz/scene", "/zenav/r1/sim/truth"})
        assert json.loads(payloads["/zenav/r1/sim/truth"][0])["v"] == 0.1
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=30) == 0
