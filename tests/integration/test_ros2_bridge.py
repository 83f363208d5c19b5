"""The ROS 2 bridge against the in-process stack through a real router, seen by a plain zenoh session
speaking rmw_zenoh's layout as a ROS 2 node (rviz2, ros2 topic echo) would."""

from __future__ import annotations

import math
import queue
import time

import pytest
import zenoh

from tests.support.rawclient import RawClient
from zenav.common.bus import ZenohBus, zenoh_config
from zenav.tools import ros2_msgs as rm
from zenav.tools import ros2bridge as rb
from zenav.tools.rmw_zenoh import Wire, attachment, parse_attachment

pytestmark = pytest.mark.timeout(120)

ODOMETRY, POSE_TYPE, TF = "nav_msgs/msg/Odometry", "geometry_msgs/msg/PoseWithCovarianceStamped", "tf2_msgs/msg/TFMessage"


@pytest.fixture
def rig(make_stack, router):
    make_stack(["sim", "motor", "odometry", "vps", "localizer", "navigator"], navigator={"stale_after": 2.0})
    raw = RawClient(router)
    raw.follow("pose")
    raw.follow("nav/state")
    raw.wait_nav_ready()
    wire = Wire(domain=3, namespace="/r1")
    bus = ZenohBus(zenoh.open(zenoh_config("client", router)))
    bridge = rb.Bridge(bus, "r1", wire).start()
    ros = zenoh.open(zenoh_config("client", router))
    yield raw, wire, bridge, ros
    ros.close()
    bridge.stop()
    bus.close()
    raw.close()


def take(ros: zenoh.Session, key: str, n: int, timeout: float = 20.0) -> list[zenoh.Sample]:
    """The next `n` samples on `key`."""
    got: queue.Queue[zenoh.Sample] = queue.Queue()
    sub = ros.declare_subscriber(key, got.put)
    try:
        return [got.get(timeout=timeout) for _ in range(n)]
    finally:
        sub.undeclare()


def test_pose_and_odometry_in_cdr_on_rmw_zenoh_keys(rig):
    raw, wire, bridge, ros = rig
    samples = take(ros, f"3/r1/odometry/nav_msgs::msg::dds_::Odometry_/{wire.type_hash(ODOMETRY)}", 3)
    seqs = []
    for s in samples:
        assert str(s.encoding) == "application/cdr"
        seq, stamp_ns, gid = parse_attachment(s.attachment.to_bytes())
        assert abs(stamp_ns / 1e9 - time.time()) < 10 and len(gid) == 16
        seqs.append(seq)
        odo = wire.deserialize(s.payload.to_bytes(), ODOMETRY)
        assert (odo.header.frame_id, odo.child_frame_id) == ("map", "base_link")
        assert abs(odo.header.stamp.sec - time.time()) < 10  # stack time made wall time by the clock's offset
        assert odo.pose.covariance[0] > 0 and odo.pose.covariance[35] > 0
    assert seqs == sorted(seqs) and len(set(seqs)) == 3
    [s] = take(ros, f"3/r1/pose/geometry_msgs::msg::dds_::PoseWithCovarianceStamped_/{wire.type_hash(POSE_TYPE)}", 1)
    pwc = wire.deserialize(s.payload.to_bytes(), POSE_TYPE)
    pose = raw.wait(lambda latest: "pose" in latest, 5)["pose"]
    assert pwc.header.frame_id == "map" and math.hypot(pwc.pose.pose.position.x - pose["x"], pwc.pose.pose.position.y - pose["y"]) < 0.5


def test_tf_tree_map_odom_base_link(rig):
    _, wire, _, ros = rig
    pairs = set()
    for s in take(ros, f"3/tf/tf2_msgs::msg::dds_::TFMessage_/{wire.type_hash(TF)}", 40):
        for tr in wire.deserialize(s.payload.to_bytes(), TF).transforms:
            pairs.add((tr.header.frame_id, tr.child_frame_id))
    assert pairs == {("map", "odom"), ("odom", "base_link")}


def test_graph_tokens_for_ros_tools(rig):
    _, wire, bridge, ros = rig
    tokens = {str(r.ok.key_expr) for r in ros.liveliness().get("@ros2_lv/3/**", timeout=5.0) if r.ok is not None}
    zid = str(bridge.bus.session.zid())
    assert f"@ros2_lv/3/{zid}/0/0/NN/%/%r1/zenav_bridge" in tokens
    kinds = {(t.split("/")[5], t.split("/")[9]) for t in tokens if t != f"@ros2_lv/3/{zid}/0/0/NN/%/%r1/zenav_bridge"}
    assert kinds == {("MP", "%r1%pose"), ("MP", "%r1%odometry"), ("MP", "%tf"), ("MS", "%r1%goal_pose")}


def test_goal_pose_drives_the_robot(rig):
    raw, wire, bridge, ros = rig
    types = wire.types()
    point = types["geometry_msgs/msg/Point"](x=0.6, y=0.3, z=0.0)
    goal = types["geometry_msgs/msg/PoseStamped"](
        header=rm.header(types, time.time(), "map"),
        pose=types["geometry_msgs/msg/Pose"](position=point, orientation=rm.quaternion(types, 0.5)),
    )
    key = f"3/r1/goal_pose/geometry_msgs::msg::dds_::PoseStamped_/{wire.type_hash('geometry_msgs/msg/PoseStamped')}"
    ros.put(key, wire.serialize(goal, "geometry_msgs/msg/PoseStamped"), attachment=attachment(1, time.time_ns(), bytes(16)))
    state = raw.wait(lambda latest: latest.get("nav/state", {}).get("state") not in (None, "STOPPED"), 15)["nav/state"]
    assert state["state"] == "MOVING_TO_POSE", state
    assert (state["goal"]["x"], state["goal"]["y"], state["goal"]["theta"]) == pytest.approx((0.6, 0.3, 0.5))
    deadline = time.monotonic() + 5.0  # the bridge counts the goal when the navigator's reply reaches it
    while bridge.counts["goals"] + bridge.counts["goals_refused"] == 0 and time.monotonic() < deadline:
        time.sleep(0.01)
    assert bridge.counts["goals"] == 1 and bridge.counts["goals_refused"] == 0
