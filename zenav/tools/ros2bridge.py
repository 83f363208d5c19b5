"""A bridge between one robot's zenav topics and ROS 2 nodes on rmw_zenoh, through the same Zenoh router.

To ROS it is a node (default `zenav_bridge`) with, by relative name (under its namespace):

- out: `odom`, `odometry`, `pose`, `/tf`, `nav/state`, `map` (latched) (tools/ros2_out.py);
- in: `cmd_vel` (geometry_msgs/Twist or TwistStamped) -> zenav's `cmd_vel` (t = 0, "now"; the
  motor applies its limits and watchdog), stopping a running goal first (`nav/stop`, once per
  goal, as `zenav teleop` does: the hand has the robot, not the goal); `initialpose`
  (geometry_msgs/PoseWithCovarianceStamped, frame `map`) -> `localizer/set_pose`;
  `goal_pose` (geometry_msgs/PoseStamped, frame `map`, rviz2's "2D Goal Pose") -> `nav/move_to_pose`;
- the actions `navigate_to_pose` and `follow_waypoints` (nav2_msgs/action/NavigateToPose and
  FollowWaypoints: tools/ros2_action.py, tools/ros2_nav2.py);
- with a [camera] given (`--image`): `camera/image_raw` and `camera/camera_info` (tools/ros2_image.py).

Bad input (CDR that does not decode, non-finite values) is dropped, counted (`bad_input`)
and logged; a message in another frame than `map`, or one the stack refuses, is counted
`refused` and logged with the reason. Zenoh callbacks only enqueue: one worker converts
and publishes zenav's topics, one command thread handles what ROS sends (in arrival order),
one decodes camera frames.
"""

from __future__ import annotations

import functools
import logging
import queue
import threading
from collections.abc import Callable
from typing import Any

from zenav.common import keys
from zenav.common import messages as m
from zenav.common.bus import Handle, ZenohBus
from zenav.common.client import Client, Latest, ZenavError
from zenav.common.config import Camera
from zenav.common.contract import State
from zenav.tools import ros2_msgs as rm
from zenav.tools import ros2_out as ro
from zenav.tools.rmw_zenoh import TRANSIENT_LOCAL, Wire
from zenav.tools.ros2_action import ActionServer
from zenav.tools.ros2_image import CameraImages
from zenav.tools.ros2_nav2 import FollowWaypoints, NavigateToPose
from zenav.tools.ros2_node import Node

log = logging.getLogger("zenav.ros2")

GOAL_POSE, CMD_VEL, INITIAL_POSE = "goal_pose", "cmd_vel", "initialpose"
SUBSCRIBED = {  # ROS topic -> the types taken on it
    GOAL_POSE: ("geometry_msgs/msg/PoseStamped",),
    CMD_VEL: ("geometry_msgs/msg/Twist", "geometry_msgs/msg/TwistStamped"),
    INITIAL_POSE: ("geometry_msgs/msg/PoseWithCovarianceStamped",),
}
MOVE_TO_POSE, SET_POSE, STOP = "nav/move_to_pose", "localizer/set_pose", "nav/stop"
STOP_TIMEOUT = 1.0  # [s] for the navigator to answer the nav/stop of a cmd_vel that takes over from a goal
INBOX = 1000  # zenav messages waiting for the worker; more are dropped (counted)
JOBS = 100  # ROS requests waiting for the command thread; more are dropped (counted)
COUNTERS = ("goals", "cmd_vel", "initial_poses", "goals_stopped", "bad_input", "refused", "dropped", "unstamped")


class Bridge:
    """Publishes one robot's state to ROS 2 and takes its commands; start() then stop()."""

    def __init__(self, bus: ZenohBus, robot: str, wire: Wire, camera: Camera | None = None) -> None:
        """`camera`: publish the camera's frames as images, with its intrinsics (None: no images)."""
        self.bus, self.robot, self.wire, self.camera = bus, robot, wire, camera
        self.client = Client(robot, bus=bus)
        self.counts: dict[str, int] = dict.fromkeys((*ro.BRIDGED, *COUNTERS), 0)
        self.converter = ro.Converter(wire.types())
        self.node: Node | None = None
        self.actions: list[ActionServer] = []
        self._frames: Handle | None = None  # the camera frames' subscription
        self._pubs: dict[str, Any] = {}
        self._nav: Latest | None = None  # the newest nav/state, as it arrives (not behind the worker's queue)
        self._stopped_goal = 0  # the goal id a cmd_vel stopped last
        self._inbox: queue.Queue[Any] = queue.Queue(INBOX)
        self._jobs: queue.Queue[Callable[[], None]] = queue.Queue(JOBS)
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []

    def keys(self) -> dict[str, str]:
        """`kind ROS name` -> the Zenoh key it travels on, for every endpoint of the node."""
        eps = self.node.endpoints if self.node is not None else []
        return {f"{ep.kind} {ep.topic}": self.wire.key(ep) for ep in eps}

    def start(self) -> Bridge:
        """Declare the ROS node, its endpoints and the zenav subscriptions; start the threads."""
        node = self.node = Node(self.bus.session, self.wire)
        self._pubs = {
            name: node.publisher(name, *ro.TYPES[name], durability=TRANSIENT_LOCAL if name in ro.LATCHED else None) for name in ro.BRIDGED
        }
        handlers = {GOAL_POSE: self._goal, CMD_VEL: self._cmd_vel, INITIAL_POSE: self._initial_pose}
        for name, ros_types in SUBSCRIBED.items():
            for ros_type in ros_types:
                node.subscription(name, ros_type, functools.partial(self._on_sample, handlers[name], ros_type))
        types = self.wire.types()
        kinds = (NavigateToPose(types), FollowWaypoints(types))
        self.actions = [ActionServer(node, self.client, self.submit, self.counts, kind) for kind in kinds]
        self._nav = self.client.latest("nav/state")
        for suffix in ("clock", "odom", "pose", "nav/state", "nav/plan", "field"):
            self.client.subscribe(suffix, self._enqueue)
        loops: list[Callable[[], None]] = [self._work, self._run_jobs]
        if self.camera is not None:
            images = CameraImages(node, self.camera, self.converter.wall_time, self.counts)
            self._frames = self.bus.subscribe(keys.field_key("camera/frame"), images.on_sample)
            loops.append(functools.partial(images.run, self._stop))
        for i, target in enumerate(loops):
            thread = threading.Thread(target=target, name=f"ros2-{('work', 'jobs', 'images')[i]}", daemon=True)
            thread.start()
            self._threads.append(thread)
        return self

    def stop(self) -> None:
        """Withdraw everything declared and end the threads (the bus stays the caller's)."""
        self._stop.set()
        for thread in self._threads:
            thread.join(timeout=5.0)
        self.client.close()
        if self._frames is not None:
            self._frames.undeclare()
        for action in self.actions:
            action.close()
        if self.node is not None:
            self.node.close()
        self.counts["unstamped"] = self.converter.unstamped

    # ------------------------------------------------------------ zenoh threads: enqueue only
    def _enqueue(self, msg: Any) -> None:
        try:
            self._inbox.put_nowait(msg)
        except queue.Full:
            self.counts["dropped"] += 1

    def _on_sample(self, handler: Callable[[bytes, str], None], ros_type: str, data: bytes) -> None:
        self.submit(functools.partial(handler, data, ros_type))

    def submit(self, job: Callable[[], None]) -> None:
        """Run `job` on the command thread, after those before it (dropped and counted if too many wait)."""
        try:
            self._jobs.put_nowait(job)
        except queue.Full:
            self.counts["dropped"] += 1

    # ------------------------------------------------------------ worker: zenav -> ROS
    def _work(self) -> None:
        while not self._stop.is_set():
            try:
                msg = self._inbox.get(timeout=0.1)
            except queue.Empty:
                continue
            try:
                self._handle(msg)
            except Exception:
                log.exception("could not bridge %s", type(msg).__name__)

    def _handle(self, msg: Any) -> None:
        for action in self.actions:
            action.on_message(msg)
        for name, ros in self.converter.feed(msg):
            self._pubs[name].put(ros)
            self.counts[name] += 1

    # ------------------------------------------------------------ command thread: ROS -> zenav
    def _run_jobs(self) -> None:
        while not self._stop.is_set():
            try:
                job = self._jobs.get(timeout=0.1)
            except queue.Empty:
                continue
            try:
                job()
            except Exception:
                log.exception("could not handle a ROS request")

    def _decode(self, data: bytes, ros_type: str, read: Callable[[Any], Any]) -> Any:
        """read(message) of a sample, or None: bad input, dropped, counted, logged."""
        try:
            return read(self.wire.deserialize(data, ros_type))
        except Exception as e:  # rosbags raises several kinds on bad CDR; read() ValueError on non-finite values
            self.counts["bad_input"] += 1
            log.warning("%s: %d bytes dropped, not a valid message: %s", ros_type, len(data), e)
            return None

    def _refused(self, what: str, why: str) -> None:
        self.counts["refused"] += 1
        log.warning("%s refused: %s", what, why)

    def _goal(self, data: bytes, ros_type: str) -> None:
        goal = self._decode(data, ros_type, rm.goal)
        if goal is None:
            return
        frame, x, y, heading = goal
        if not rm.in_map(frame):
            self._refused(GOAL_POSE, f"frame {frame!r}: goals are in {rm.MAP!r}")
            return
        try:
            reply = self.client.query(MOVE_TO_POSE, {"x": x, "y": y, "theta": heading})
        except ZenavError as e:
            self._refused(GOAL_POSE, str(e))
            return
        self.counts["goals"] += 1
        log.info("%s (%.3f, %.3f, %.3f): goal %s %s", GOAL_POSE, x, y, heading, reply.goal_id, reply.state)

    def _cmd_vel(self, data: bytes, ros_type: str) -> None:
        cmd = self._decode(data, ros_type, rm.velocity)
        if cmd is None:
            return
        nav = None if self._nav is None else self._nav.msg
        if cmd != (0.0, 0.0) and nav is not None and nav.state != State.STOPPED and nav.goal_id != self._stopped_goal:
            self._stopped_goal = nav.goal_id
            try:
                self.client.query(STOP, timeout=STOP_TIMEOUT)
                self.counts["goals_stopped"] += 1
                log.info("%s: stopped goal %d to drive by cmd_vel", CMD_VEL, nav.goal_id)
            except ZenavError as e:
                log.warning("%s: %s failed: %s", CMD_VEL, STOP, e)
        self.client.publish("cmd_vel", m.CmdVel(t=0.0, v=cmd[0], omega=cmd[1]))
        self.counts["cmd_vel"] += 1

    def _initial_pose(self, data: bytes, ros_type: str) -> None:
        pose = self._decode(data, ros_type, rm.goal)
        if pose is None:
            return
        frame, x, y, theta = pose
        if not rm.in_map(frame):
            self._refused(INITIAL_POSE, f"frame {frame!r}: poses are in {rm.MAP!r}")
            return
        try:
            self.client.query(SET_POSE, {"x": x, "y": y, "theta": theta})
        except ZenavError as e:
            self._refused(INITIAL_POSE, str(e))
            return
        self.counts["initial_poses"] += 1
        log.info("%s: pose set to (%.3f, %.3f, %.3f)", INITIAL_POSE, x, y, theta)
