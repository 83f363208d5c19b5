"""The ROS 2 bridge against the in-process stack through a real router, seen by a plain zenoh session
speaking rmw_zenoh's layout as a ROS 2 node (rviz2, ros2 topic echo, teleop, an action client) would."""

from __future__ import annotations

import functools
import math
import queue
import threading
import time
import uuid

import numpy as np
import pytest
import zenoh
import zenoh.ext

from tests.support.rawclient import RawClient
from zenav.common import codec, keys
from zenav.common import messages as m
from zenav.common.bus import ZenohBus, zenoh_config
from zenav.common.config import Camera
from zenav.services.vps import frames
from zenav.tools import ros2_msgs as rm
from zenav.tools import ros2_types as rt
from zenav.tools import ros2bridge as rb
from zenav.tools.rmw_zenoh import Wire, attachment, parse_attachment

pytestmark = pytest.mark.timeout(120)

ODOMETRY, POSE_TYPE, TF = "nav_msgs/msg/Odometry", "geometry_msgs/msg/PoseWithCovarianceStamped", "tf2_msgs/msg/TFMessage"
GRID = "nav_msgs/msg/OccupancyGrid"
IMAGE, INFO = "sensor_msgs/msg/Image", "sensor_msgs/msg/CameraInfo"
BOX = {"name": "box", "polygon": [[2.4, 2.4], [2.6, 2.4], [2.6, 2.6], [2.4, 2.6]]}  # out of the tests' way


@pytest.fixture
def rig(make_stack, router):
    make_stack(["sim", "motor", "odometry", "vps", "localizer", "navigator"], navigator={"stale_after": 2.0}, field={"obstacles": [BOX]})
    raw = RawClient(router)
    raw.follow("pose")
    raw.follow("nav/state")
    raw.wait_nav_ready()
    wire = Wire(domain=3, namespace="/r1")
    bus = ZenohBus(zenoh.open(zenoh_config("client", router)))
    bridge = rb.Bridge(bus, "r1", wire).start()
    rt.register(wire)  # the test's own types, as a ROS node has them
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
    kinds = {(t.split("/")[5], t.split("/")[9], t.split("/")[10]) for t in tokens if t != f"@ros2_lv/3/{zid}/0/0/NN/%/%r1/zenav_bridge"}
    action, waypoints = "%r1%navigate_to_pose%_action%", "%r1%follow_waypoints%_action%"
    assert kinds == {
        ("MP", "%r1%pose", "geometry_msgs::msg::dds_::PoseWithCovarianceStamped_"),
        ("MP", "%r1%odometry", "nav_msgs::msg::dds_::Odometry_"),
        ("MP", "%r1%odom", "nav_msgs::msg::dds_::Odometry_"),
        ("MP", "%tf", "tf2_msgs::msg::dds_::TFMessage_"),
        ("MP", "%r1%nav%state", "std_msgs::msg::dds_::String_"),
        ("MP", "%r1%map", "nav_msgs::msg::dds_::OccupancyGrid_"),
        ("MS", "%r1%goal_pose", "geometry_msgs::msg::dds_::PoseStamped_"),
        ("MS", "%r1%cmd_vel", "geometry_msgs::msg::dds_::Twist_"),
        ("MS", "%r1%cmd_vel", "geometry_msgs::msg::dds_::TwistStamped_"),
        ("MS", "%r1%initialpose", "geometry_msgs::msg::dds_::PoseWithCovarianceStamped_"),
        ("SS", action + "send_goal", "nav2_msgs::action::dds_::NavigateToPose_SendGoal_"),
        ("SS", action + "cancel_goal", "action_msgs::srv::dds_::CancelGoal_"),
        ("SS", action + "get_result", "nav2_msgs::action::dds_::NavigateToPose_GetResult_"),
        ("MP", action + "feedback", "nav2_msgs::action::dds_::NavigateToPose_FeedbackMessage_"),
        ("MP", action + "status", "action_msgs::msg::dds_::GoalStatusArray_"),
        ("SS", waypoints + "send_goal", "nav2_msgs::action::dds_::FollowWaypoints_SendGoal_"),
        ("SS", waypoints + "cancel_goal", "action_msgs::srv::dds_::CancelGoal_"),
        ("SS", waypoints + "get_result", "nav2_msgs::action::dds_::FollowWaypoints_GetResult_"),
        ("MP", waypoints + "feedback", "nav2_msgs::action::dds_::FollowWaypoints_FeedbackMessage_"),
        ("MP", waypoints + "status", "action_msgs::msg::dds_::GoalStatusArray_"),
    }
    for status in (t for t in tokens if "%status/" in t):
        assert status.endswith("/:1:,1:,:,:,,")  # transient local, depth 1, as rcl's action status QoS
    latched_map = next(t for t in tokens if "%r1%map/" in t)
    assert latched_map.endswith("/:1:,1:,:,:,,")  # as a map server's


def test_the_field_is_a_latched_map_for_late_subscribers(rig):
    """rviz2 or Nav2 started after the bridge still get the map: from the advanced publisher's cache
    (rmw_zenoh on zenoh 1.1+) and from the publication-cache query of earlier rmw_zenoh releases."""
    _, wire, bridge, ros = rig
    key = f"3/r1/map/nav_msgs::msg::dds_::OccupancyGrid_/{wire.type_hash(GRID)}"
    got: queue.Queue[zenoh.Sample] = queue.Queue()
    late = zenoh.ext.declare_advanced_subscriber(ros, key, got.put, history=zenoh.ext.HistoryConfig(detect_late_publishers=True))
    try:
        first = got.get(timeout=20.0)
    finally:
        late.undeclare()
    grid = wire.deserialize(first.payload.to_bytes(), GRID)
    assert (grid.header.frame_id, grid.info.width, grid.info.height) == ("map", 200, 200)  # the default field, 4 m x 4 m
    cells = np.asarray(grid.data).reshape(200, 200)
    assert cells[175, 175] == rm.OCCUPIED and cells[50, 50] == rm.FREE  # (2.5, 2.5) m inside the box; (0, 0) free
    assert int((cells == rm.OCCUPIED).sum()) == 100
    replies = [r.ok for r in ros.get(f"*/{key}", timeout=5.0, accept_replies=zenoh.ReplyKeyExpr.ANY) if r.ok is not None]
    assert [str(r.key_expr) for r in replies] == [key]
    assert wire.deserialize(replies[0].payload.to_bytes(), GRID).data.tolist() == grid.data.tolist()
    assert bridge.counts["map"] == 1  # sent once: the field has not changed


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
    wait_count(bridge, "goals", 1)  # the bridge counts the goal when the navigator's reply reaches it
    assert bridge.counts["goals"] == 1 and bridge.counts["refused"] == 0


def key_of(wire: Wire, name: str, ros_type: str) -> str:
    """The key a ROS node on the test's wire uses for `name` (relative to /r1) and `ros_type`."""
    return wire.key(wire.endpoint("MP", name, ros_type))


def wait_count(bridge: rb.Bridge, name: str, n: int, timeout: float = 10.0) -> None:
    """Until the bridge has counted `name` n times (it counts on its own thread, after the sample arrived)."""
    deadline = time.monotonic() + timeout
    while bridge.counts[name] < n and time.monotonic() < deadline:
        time.sleep(0.01)
    assert bridge.counts[name] >= n, bridge.counts


def twist(wire: Wire, v: float, omega: float, stamped: bool = False) -> tuple[str, bytes]:
    types = wire.types()
    tw = rm.twist_msg(types, v, omega)
    if stamped:
        ros_type, msg = (
            "geometry_msgs/msg/TwistStamped",
            types["geometry_msgs/msg/TwistStamped"](header=rm.header(types, time.time(), "base_link"), twist=tw),
        )
    else:
        ros_type, msg = "geometry_msgs/msg/Twist", tw
    return key_of(wire, "cmd_vel", ros_type), wire.serialize(msg, ros_type)


@pytest.mark.parametrize("stamped", [False, True])
def test_cmd_vel_drives_the_robot(rig, stamped):
    raw, wire, bridge, ros = rig
    start = raw.wait(lambda latest: "pose" in latest, 10)["pose"]
    key, data = twist(wire, 0.2, 0.0, stamped)
    moved = None
    for seq in range(1, 101):  # 20 Hz as a teleop node sends, 5 s at most
        # with rmw_zenoh's attachment, and (TwistStamped) without: both are taken
        ros.put(key, data, attachment=None if stamped else attachment(seq, time.time_ns(), bytes(16)))
        pose = raw.latest["pose"]
        if math.hypot(pose["x"] - start["x"], pose["y"] - start["y"]) > 0.05:
            moved = pose
            break
        time.sleep(0.05)  # the sender's pace, not a synchronisation
    assert moved is not None, "the robot did not move"
    ros.put(key, twist(wire, 0.0, 0.0, stamped)[1])
    assert bridge.counts["cmd_vel"] >= 2 and bridge.counts["bad_input"] == 0


def test_cmd_vel_takes_over_from_a_goal(rig):
    raw, wire, bridge, ros = rig
    raw.query("nav/move_to_point", {"x": 0.8, "y": 0.0})
    raw.wait(lambda latest: latest.get("nav/state", {}).get("state") == "MOVING_TO_POINT", 10)
    key, data = twist(wire, 0.0, 0.5)
    ros.put(key, data)
    state = raw.wait(lambda latest: latest.get("nav/state", {}).get("result") is not None, 10)["nav/state"]
    assert state["result"] == "cancelled"
    wait_count(bridge, "goals_stopped", 1)


def test_initialpose_resets_the_localizer(rig):
    raw, wire, bridge, ros = rig
    types = wire.types()
    ros_type = "geometry_msgs/msg/PoseWithCovarianceStamped"
    msg = rm.pose_with_covariance(types, m.Pose(t=0.0, x=0.7, y=-0.4, theta=1.2, v=0.0, omega=0.0), time.time())
    ros.put(key_of(wire, "initialpose", ros_type), wire.serialize(msg, ros_type), attachment=attachment(1, time.time_ns(), bytes(16)))
    pose = raw.wait(lambda latest: abs(latest["pose"]["x"] - 0.7) < 0.02 and abs(latest["pose"]["y"] + 0.4) < 0.02, 10)["pose"]
    assert pose["theta"] == pytest.approx(1.2, abs=0.02)
    wait_count(bridge, "initial_poses", 1)


def test_bad_input_dropped_and_counted(rig):
    raw, wire, bridge, ros = rig
    key, data = twist(wire, 0.1, 0.0)
    ros.put(key, b"\x00\x01\x00\x00\x01")  # CDR that ends inside the first double
    ros.put(key.rsplit("/", 1)[0] + "/RIHS01_" + "0" * 64, b"not cdr")  # another definition's hash: taken, and bad
    nan = wire.serialize(rm.twist_msg(wire.types(), float("nan"), 0.0), "geometry_msgs/msg/Twist")
    ros.put(key, nan)
    wait_count(bridge, "bad_input", 3)
    ros.put(
        key_of(wire, "goal_pose", "geometry_msgs/msg/PoseStamped"),
        wire.serialize(goal_msg(wire, 0.3, 0.3, frame="odom"), "geometry_msgs/msg/PoseStamped"),
    )
    wait_count(bridge, "refused", 1)
    assert bridge.counts["cmd_vel"] == 0 and bridge.counts["goals"] == 0


def goal_msg(wire: Wire, x: float, y: float, theta: float = 0.0, frame: str = "map"):
    types = wire.types()
    return (
        rm.pose_stamped(types, time.time(), (x, y, theta))
        if frame == "map"
        else types["geometry_msgs/msg/PoseStamped"](
            header=rm.header(types, time.time(), frame), pose=rm.pose_stamped(types, 0.0, (x, y, theta)).pose
        )
    )


class ActionClient:
    """An action (navigate_to_pose unless told) as rclpy's ActionClient uses it on rmw_zenoh: gets on the services,
    a subscription on feedback."""

    def __init__(self, ros: zenoh.Session, wire: Wire, name: str = "navigate_to_pose", action: str = rt.NAVIGATE) -> None:
        self.ros, self.wire, self.seq = ros, wire, 0
        self.base = f"{name}/_action/"
        self.feedback: queue.Queue = queue.Queue()
        fb = wire.endpoint("MS", self.base + "feedback", f"{action}_FeedbackMessage")
        self.sub = ros.declare_subscriber(wire.key(fb), lambda s: self.feedback.put(wire.deserialize(s.payload.to_bytes(), fb.ros_type)))

    def call(self, service: str, srv_type: str, request, timeout: float = 10.0):
        self.seq += 1
        seq = self.seq  # its own: calls run on several threads
        key = self.wire.key(self.wire.endpoint("SC", self.base + service, srv_type))
        types = self.wire.types()
        data = self.wire.serialize(types[f"{srv_type}_Request"](**request), f"{srv_type}_Request")
        replies = list(self.ros.get(key, payload=data, attachment=attachment(seq, time.time_ns(), b"c" * 16), timeout=timeout))
        assert len(replies) == 1 and replies[0].ok is not None, replies
        reply = replies[0].ok
        assert parse_attachment(reply.attachment.to_bytes())[0::2] == (seq, b"c" * 16)  # the request's number and GID back
        return self.wire.deserialize(reply.payload.to_bytes(), f"{srv_type}_Response")

    def uuid(self):
        return self.wire.types()["unique_identifier_msgs/msg/UUID"](uuid=np.frombuffer(uuid.uuid4().bytes, dtype="uint8").copy())


def test_navigate_to_pose_action_succeeds_with_feedback(rig):
    raw, wire, bridge, ros = rig
    client = ActionClient(ros, wire)
    goal_id = client.uuid()
    goal = wire.types()[f"{rt.NAVIGATE}_Goal"](pose=goal_msg(wire, 0.5, 0.2, 0.6), behavior_tree="")
    reply = client.call("send_goal", f"{rt.NAVIGATE}_SendGoal", {"goal_id": goal_id, "goal": goal})
    assert reply.accepted and abs(reply.stamp.sec - time.time()) < 10
    result = client.call("get_result", f"{rt.NAVIGATE}_GetResult", {"goal_id": goal_id}, timeout=60.0)  # answered when it ends
    assert result.status == 4, result  # SUCCEEDED
    assert (result.result.error_code, result.result.error_msg) == (0, "")
    pose = raw.latest["pose"]
    assert math.hypot(pose["x"] - 0.5, pose["y"] - 0.2) < 0.05
    feedback = []
    while not client.feedback.empty():  # every feedback came before the result: the queue holds them all
        feedback.append(client.feedback.get_nowait())
    assert len(feedback) >= 3 and all(bytes(f.goal_id.uuid) == bytes(goal_id.uuid) for f in feedback)
    first, last = feedback[0].feedback, feedback[-1].feedback
    assert first.distance_remaining > 0.4 and 0.0 <= last.distance_remaining < first.distance_remaining - 0.3
    assert last.navigation_time.sec + last.navigation_time.nanosec * 1e-9 > first.navigation_time.sec + first.navigation_time.nanosec * 1e-9
    assert feedback[0].feedback.current_pose.header.frame_id == "map"
    client.sub.undeclare()


def test_navigate_to_pose_outside_the_field_aborts_saying_why(rig):
    raw, wire, bridge, ros = rig
    client = ActionClient(ros, wire)
    goal_id = client.uuid()
    goal = wire.types()[f"{rt.NAVIGATE}_Goal"](pose=goal_msg(wire, 50.0, 0.0), behavior_tree="")
    assert client.call("send_goal", f"{rt.NAVIGATE}_SendGoal", {"goal_id": goal_id, "goal": goal}).accepted
    result = client.call("get_result", f"{rt.NAVIGATE}_GetResult", {"goal_id": goal_id})
    assert result.status == 6 and result.result.error_code == rt.UNKNOWN, result  # ABORTED
    assert "outside the field ([field] x_max" in result.result.error_msg
    assert bridge.counts["action_refused"] == 1
    client.sub.undeclare()


def test_navigate_to_pose_cancelled(rig):
    raw, wire, bridge, ros = rig
    client = ActionClient(ros, wire)
    goal_id = client.uuid()
    goal = wire.types()[f"{rt.NAVIGATE}_Goal"](pose=goal_msg(wire, 0.8, -0.5), behavior_tree="")
    assert client.call("send_goal", f"{rt.NAVIGATE}_SendGoal", {"goal_id": goal_id, "goal": goal}).accepted
    results: queue.Queue = queue.Queue()
    waiter = threading.Thread(target=lambda: results.put(client.call("get_result", f"{rt.NAVIGATE}_GetResult", {"goal_id": goal_id}, 30.0)))
    waiter.start()
    raw.wait(lambda latest: latest.get("nav/state", {}).get("state") == "MOVING_TO_POSE", 10)
    types = wire.types()
    info = types["action_msgs/msg/GoalInfo"](goal_id=goal_id, stamp=rm.stamp(types, 0.0))
    cancel = client.call("cancel_goal", rt.CANCEL, {"goal_info": info})
    assert cancel.return_code == 0 and [bytes(g.goal_id.uuid) for g in cancel.goals_canceling] == [bytes(goal_id.uuid)]
    waiter.join(30.0)
    assert results.get(timeout=1.0).status == 5  # CANCELED
    client.sub.undeclare()


# ---------------------------------------------------------------- follow_waypoints
WAYPOINTS = ((0.4, 0.0), (0.4, 0.4), (0.0, 0.4))


def waypoints_goal(client: ActionClient, wire: Wire, points) -> tuple:
    """Send a FollowWaypoints goal of `points` (x, y) in map; its goal id once accepted."""
    goal_id = client.uuid()
    goal = wire.types()[f"{rt.FOLLOW}_Goal"](number_of_loops=0, goal_index=0, poses=[goal_msg(wire, x, y) for x, y in points])
    assert client.call("send_goal", f"{rt.FOLLOW}_SendGoal", {"goal_id": goal_id, "goal": goal}).accepted
    return goal_id


def test_follow_waypoints_succeeds_with_feedback(rig):
    raw, wire, bridge, ros = rig
    client = ActionClient(ros, wire, "follow_waypoints", rt.FOLLOW)
    goal_id = waypoints_goal(client, wire, WAYPOINTS)
    result = client.call("get_result", f"{rt.FOLLOW}_GetResult", {"goal_id": goal_id}, timeout=90.0)  # answered when it ends
    assert result.status == 4, result  # SUCCEEDED
    assert (list(result.result.missed_waypoints), result.result.error_code, result.result.error_msg) == ([], 0, "")
    pose = raw.latest["pose"]
    assert math.hypot(pose["x"] - WAYPOINTS[-1][0], pose["y"] - WAYPOINTS[-1][1]) < 0.06
    seen = []
    while not client.feedback.empty():  # every feedback came before the result
        fb = client.feedback.get_nowait()
        assert bytes(fb.goal_id.uuid) == bytes(goal_id.uuid)
        seen.append(fb.feedback.current_waypoint)
    assert seen == sorted(seen) and set(seen) == {0, 1, 2}, seen  # each waypoint in turn
    assert bridge.counts["action_refused"] == 0
    client.sub.undeclare()


def test_follow_waypoints_cancelled(rig):
    raw, wire, bridge, ros = rig
    client = ActionClient(ros, wire, "follow_waypoints", rt.FOLLOW)
    goal_id = waypoints_goal(client, wire, ((0.8, -0.5), (0.8, 0.5)))
    raw.wait(lambda latest: latest.get("nav/state", {}).get("state") == "FOLLOWING_PATH", 10)
    types = wire.types()
    info = types["action_msgs/msg/GoalInfo"](goal_id=goal_id, stamp=rm.stamp(types, 0.0))
    cancel = client.call("cancel_goal", rt.CANCEL, {"goal_info": info})
    assert cancel.return_code == 0 and [bytes(g.goal_id.uuid) for g in cancel.goals_canceling] == [bytes(goal_id.uuid)]
    result = client.call("get_result", f"{rt.FOLLOW}_GetResult", {"goal_id": goal_id}, timeout=30.0)
    assert result.status == 5 and list(result.result.missed_waypoints) == [], result  # CANCELED
    state = raw.wait(lambda latest: latest.get("nav/state", {}).get("result") is not None, 10)["nav/state"]
    assert state["result"] == "cancelled"
    client.sub.undeclare()


def test_follow_waypoints_outside_the_field_aborts_saying_why(rig):
    raw, wire, bridge, ros = rig
    client = ActionClient(ros, wire, "follow_waypoints", rt.FOLLOW)
    goal_id = waypoints_goal(client, wire, ((0.3, 0.0), (50.0, 0.0), (0.3, 0.3)))
    result = client.call("get_result", f"{rt.FOLLOW}_GetResult", {"goal_id": goal_id})
    assert result.status == 6 and result.result.error_code == rt.WAYPOINTS_UNKNOWN, result  # ABORTED, before it started
    assert "outside the field ([field] x_max" in result.result.error_msg and "points[1]" in result.result.error_msg
    assert list(result.result.missed_waypoints) == []
    assert bridge.counts["action_refused"] == 1 and raw.latest["nav/state"]["state"] == "STOPPED"
    client.sub.undeclare()


# ---------------------------------------------------------------- camera frames
CAMERA = Camera(width=64, height=48, fx=70.0, fy=71.0, cx=30.0, k1=-0.05, rate_hz=50.0)


@pytest.fixture
def image_rig(router):
    """The bridge with --image's camera, no stack: the test sends the frames as `zenav camera stream` does."""
    pytest.importorskip("cv2")
    wire = Wire(domain=3, namespace="/r1")
    bus = ZenohBus(zenoh.open(zenoh_config("client", router)))
    bridge = rb.Bridge(bus, "r1", wire, CAMERA).start()
    ros = zenoh.open(zenoh_config("client", router))
    yield wire, bridge, ros
    ros.close()
    bridge.stop()
    bus.close()


def test_camera_frames_as_image_and_camera_info(image_rig):
    wire, bridge, ros = image_rig
    grey = np.add.outer(np.arange(48), np.arange(64)).astype(np.uint8) * 2
    got: queue.Queue[tuple[str, zenoh.Sample]] = queue.Queue()
    keys_ = {name: key_of(wire, name, ros_type) for name, ros_type in (("camera/image_raw", IMAGE), ("camera/camera_info", INFO))}
    subs = [ros.declare_subscriber(key, functools.partial(lambda n, s: got.put((n, s)), name)) for name, key in keys_.items()]
    frame_key = keys.field_key("camera/frame")
    received: dict[str, zenoh.Sample] = {}
    try:
        for seq in range(40):  # a frame each 0.25 s at most until both messages came (the bridge's subscription takes a moment)
            ros.put(frame_key, codec.encode(frames.encode(grey, time.time(), seq, encoding="png")))
            try:
                while len(received) < 2:
                    name, sample = got.get(timeout=0.25)
                    received[name] = sample
                break
            except queue.Empty:
                continue
    finally:
        for sub in subs:
            sub.undeclare()
    img = wire.deserialize(received["camera/image_raw"].payload.to_bytes(), IMAGE)
    assert (img.encoding, img.width, img.height, img.step, img.header.frame_id) == ("mono8", 64, 48, 64, "camera")
    assert np.array_equal(np.asarray(img.data).reshape(48, 64), grey)  # PNG: lossless
    assert abs(img.header.stamp.sec - time.time()) < 10
    info = wire.deserialize(received["camera/camera_info"].payload.to_bytes(), INFO)
    assert (info.width, info.height, info.distortion_model, info.header.frame_id) == (64, 48, "plumb_bob", "camera")
    assert info.k.tolist() == [70.0, 0.0, 30.0, 0.0, 71.0, 24.0, 0.0, 0.0, 1.0]
    assert info.d.tolist() == [-0.05, 0.0, 0.0, 0.0, 0.0]
    ros.put(frame_key, b"\x93not a frame")  # dropped, counted (the bridge's subscription is there: images came)
    wait_count(bridge, "image_bad_input", 1)
    wait_count(bridge, "images", 1)  # counted once both are sent
