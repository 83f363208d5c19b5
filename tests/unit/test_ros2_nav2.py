"""FollowWaypoints and NavigateToPose as zenav goals: the path sent, the waypoint reported, the results per distro."""

from __future__ import annotations

import threading

import pytest

from zenav.common import messages as m
from zenav.common.config import Camera
from zenav.tools import ros2_action as ra
from zenav.tools import ros2_image as ri
from zenav.tools import ros2_msgs as rm
from zenav.tools import ros2_nav2 as rn
from zenav.tools import ros2_types as rt
from zenav.tools.rmw_zenoh import Wire


def test_path_order_from_goal_index_and_loops():
    assert rn.path_order(3) == [0, 1, 2]
    assert rn.path_order(3, goal_index=1, loops=2) == [1, 2, 0, 1, 2, 0, 1, 2]
    for args, words in (((0,), "no poses"), ((3, 3), "goal_index 3: the goal has 3 poses"), ((5, 0, 2**32 - 1), "over 10000 points")):
        with pytest.raises(ValueError, match=words):
            rn.path_order(*args)


def test_path_index_skips_the_planned_detours():
    path = [(1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
    plan = [(1.0, 0.0), (1.2, 0.5), (1.0, 1.0), (0.0, 1.0)]  # a detour corner before the second point
    assert [rn.path_index(i, plan, path) for i in range(4)] == [0, 1, 1, 2]
    assert [rn.path_index(i, None, path) for i in (0, 2, 7)] == [0, 2, 2]  # no plan known: the path itself


def follow_goal(wire: Wire, points, loops: int = 0, goal_index: int = 0, frame: str = "map") -> ra.Goal:
    types = wire.types()
    poses = [
        types["geometry_msgs/msg/PoseStamped"](header=rm.header(types, 0.0, frame), pose=rm.pose_stamped(types, 0.0, (x, y, 0.0)).pose)
        for x, y in points
    ]
    fields = {"poses": poses} if wire.distro == "humble" else {"poses": poses, "number_of_loops": loops, "goal_index": goal_index}
    return ra.Goal(b"\x01" * 16, 0.0, types[f"{rt.FOLLOW}_Goal"](**fields))


def wire_of(distro: str) -> Wire:
    wire = Wire(distro=distro)
    rt.register(wire)
    return wire


def state(**fields) -> m.NavState:
    return m.NavState(t=1.0, state="FOLLOWING_PATH", goal_id=7, **fields)


@pytest.mark.parametrize("distro", ["humble", "jazzy", "kilted"])
def test_follow_waypoints_feedback_and_an_aborted_result_name_the_waypoint(distro):
    wire = wire_of(distro)
    kind = rn.FollowWaypoints(wire.types())
    goal = follow_goal(wire, [(0.5, 0.0), (0.5, 0.5), (0.0, 0.5)], loops=1, goal_index=1)  # Humble: no loops, no goal_index
    sent = [[0.5, 0.0], [0.5, 0.5], [0.0, 0.5]] if distro == "humble" else [[0.5, 0.5], [0.0, 0.5], [0.5, 0.0], [0.5, 0.5], [0.0, 0.5]]
    assert kind.start(goal) == ("nav/follow_path", {"points": sent})
    plan = [*sent[:2], [0.3, 0.2], *sent[2:]]  # a detour corner planned before the third point
    kind.observe(m.Plan(t=1.0, goal_id=7, points=plan, length=3.0, planned=True))
    expected = 2 if distro == "humble" else 0  # the third point sent: pose 2, or pose 0 of the second round
    assert kind.feedback(goal, state(next_point=3)).current_waypoint == expected
    result = kind.result(goal, ra.ABORTED, "no progress for 5 s", state(next_point=3, result="aborted", exit="stalled"))
    if distro == "humble":
        assert list(result.missed_waypoints) == [2]
        return
    [missed] = result.missed_waypoints
    assert (result.error_code, result.error_msg) == (rt.TASK_EXECUTOR_FAILED, "no progress for 5 s")
    if distro == "jazzy":
        assert (missed.index, missed.goal.pose.position.x, missed.error_code) == (0, 0.5, rt.UNKNOWN)
    else:
        assert (missed.waypoint_status, missed.waypoint_index, missed.error_msg) == (rt.WAYPOINT_FAILED, 0, "no progress for 5 s")


@pytest.mark.parametrize(
    ("status", "message", "code"), [(ra.SUCCEEDED, "", rt.NONE), (ra.CANCELED, "stopped", rt.NONE), (ra.ABORTED, "outside", 600)]
)
def test_follow_waypoints_results_without_a_missed_waypoint(status, message, code):
    wire = wire_of("jazzy")
    kind = rn.FollowWaypoints(wire.types())
    goal = follow_goal(wire, [(0.5, 0.0)])
    kind.start(goal)
    result = kind.result(goal, status, message, None if status == ra.ABORTED else state(result="x"))  # ABORTED: refused
    assert (list(result.missed_waypoints), result.error_code, result.error_msg) == ([], code, message)


def test_follow_waypoints_refuses_another_frame_and_nan():
    wire = wire_of("jazzy")
    kind = rn.FollowWaypoints(wire.types())
    with pytest.raises(ValueError, match="poses\\[0\\] in frame 'odom'"):
        kind.start(follow_goal(wire, [(0.5, 0.0)], frame="odom"))
    with pytest.raises(ValueError, match="not finite"):
        kind.start(follow_goal(wire, [(0.5, float("nan"))]))


class _Publisher:
    def __init__(self) -> None:
        self.sent: list = []

    def put(self, msg) -> None:
        self.sent.append(msg)


class _Node:
    """The part of a Node CameraImages uses, in memory."""

    def __init__(self, wire: Wire) -> None:
        self.wire, self.pubs = wire, {}

    def publisher(self, name, ros_type, depth=10, durability=None):
        return self.pubs.setdefault(name, _Publisher())


def test_camera_images_keep_the_newest_frame_and_count_the_rest():
    pytest.importorskip("cv2")
    from zenav.common import codec
    from zenav.services.vps import frames

    node, counts = _Node(Wire()), {}
    images = ri.CameraImages(node, Camera(width=32, height=24), lambda t: t, counts)  # type: ignore[arg-type]
    grey = [bytes([i]) * (32 * 24) for i in (10, 20, 30)]
    for i, data in enumerate(grey):
        images.on_sample("k", codec.encode(m.CameraFrame(t=2e9 + i, seq=i, width=32, height=24, data=data)))
    stop = threading.Event()
    data = images._take(stop)
    assert data is not None and counts["image_dropped"] == 2
    images.publish(data)
    [img] = node.pubs[ri.IMAGE].sent
    assert bytes(img.data[:1]) == b"\x1e" and img.header.stamp.sec == 2_000_000_002  # the newest, its own stamp
    images.publish(codec.encode(frames.encode(__import__("numpy").zeros((10, 10), "uint8"), 2e9, 0)))  # not the camera's size
    assert counts["image_bad_input"] == 1 and counts["images"] == 1
