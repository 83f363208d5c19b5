"""`zenav record --ros2` as a process on a real router, against the in-process stack: the bag read back by rosbags' reader."""

from __future__ import annotations

import json
import math
import signal
import subprocess
import sys

import pytest
from mcap.reader import make_reader
from rosbags.rosbag2 import Reader

from tests.support.procs import reaped, stderr_lines
from tests.support.rawclient import RawClient
from zenav.tools.rmw_zenoh import Wire

pytestmark = pytest.mark.timeout(180)

TYPES = {
    "/odom": "nav_msgs/msg/Odometry",
    "/odometry": "nav_msgs/msg/Odometry",
    "/pose": "geometry_msgs/msg/PoseWithCovarianceStamped",
    "/tf": "tf2_msgs/msg/TFMessage",
    "/nav/state": "std_msgs/msg/String",
    "/cmd_vel": "geometry_msgs/msg/Twist",
    "/map": "nav_msgs/msg/OccupancyGrid",
}


def test_a_driven_goal_recorded_as_a_ros2_bag(make_stack, router, tmp_path):
    make_stack(["sim", "motor", "odometry", "vps", "localizer", "navigator"], navigator={"stale_after": 2.0})
    raw = RawClient(router)
    raw.follow("pose")
    raw.follow("nav/state")
    raw.wait_nav_ready()
    bag = tmp_path / "run"
    proc = subprocess.Popen(
        [sys.executable, "-m", "zenav", "record", str(bag), "--ros2", "--distro", "jazzy", "--connect", router],
        stderr=subprocess.PIPE,
        text=True,
    )
    lines = stderr_lines(proc)
    with reaped(proc):
        assert "recording zenav/r1/**" in lines.get(timeout=60)
        ok, reply = raw.query("nav/move_to_point", {"x": 0.4, "y": 0.0, "wait": True}, timeout=60.0)
        assert ok and reply["result"] == "succeeded", reply
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=60) == 0
    raw.close()
    summary = lines.get(timeout=10)
    assert f"{bag}: " in summary and " messages on 7 topics" in summary, summary

    wire = Wire(distro="jazzy")
    with Reader(bag) as reader:
        assert {c.topic: c.msgtype for c in reader.connections} == TYPES
        counts = {c.topic: c.msgcount for c in reader.connections}
        assert counts["/pose"] > 20 and counts["/odom"] >= counts["/pose"] and counts["/tf"] >= counts["/odom"]
        assert counts["/cmd_vel"] > 5 and counts["/nav/state"] > 2 and counts["/map"] == 1  # the field did not change
        [latched] = [c.ext.offered_qos_profiles for c in reader.connections if c.topic == "/map"]
        assert [(q.durability.name, q.depth) for q in latched] == [("TRANSIENT_LOCAL", 1)]  # replayed latched, as a map server's
        assert all(c.digest == wire.type_hash(c.msgtype) for c in reader.connections)  # the RIHS01 hashes ROS checks
        last: dict[str, object] = {}
        for conn, _, data in reader.messages():
            last[conn.topic] = wire.deserialize(data, conn.msgtype)
    pose, state = last["/pose"], json.loads(last["/nav/state"].data)
    assert pose.header.frame_id == "map" and math.hypot(pose.pose.pose.position.x - 0.4, pose.pose.pose.position.y) < 0.05
    assert last["/odom"].header.frame_id == "odom" and last["/odom"].child_frame_id == "base_link"
    assert state["result"] == "succeeded" and state["goal"]["x"] == 0.4
    [mcap_file] = bag.glob("*.mcap")
    with open(mcap_file, "rb") as f:  # laid out as rosbag2's mcap storage: ros2msg schemas, cdr messages
        mcap = make_reader(f).get_summary()
    assert mcap is not None
    assert {s.encoding for s in mcap.schemas.values()} == {"ros2msg"} and {c.message_encoding for c in mcap.channels.values()} == {"cdr"}
    assert {s.name for s in mcap.schemas.values()} == set(TYPES.values())
