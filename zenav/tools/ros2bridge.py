"""A bridge between one robot's zenav topics and ROS 2 nodes on rmw_zenoh, through the same Zenoh router.

To ROS it is a node (default `zenav_bridge`) that publishes, with the types and key
layout of rmw_zenoh (tools/rmw_zenoh.py):

- `pose` (geometry_msgs/msg/PoseWithCovarianceStamped) and `odometry` (nav_msgs/msg/Odometry):
  the fused pose, in `map`, for every zenav `pose`;
- `/tf` (tf2_msgs/msg/TFMessage): `odom -> base_link` for every zenav `odom`, and
  `map -> odom` for every `pose` whose odom sample (same t) it has seen;

and takes goals on `goal_pose` (geometry_msgs/msg/PoseStamped, frame `map`, rviz2's
"2D Goal Pose" tool) as `nav/move_to_pose` with the goal's heading. Relative names go under the node's namespace.

Stamps are wall time: a wall-clock stack's t is wall time already; a sim clock's t (under
WALL_SINCE) gets the offset its `clock` topic gives (wall - t), and samples wait for it.
Zenoh callbacks only enqueue; one thread converts and publishes, another sends goals.
"""

from __future__ import annotations

import functools
import logging
import queue
import threading
import time
from collections import OrderedDict
from typing import Any

import zenoh

from zenav.common import messages as m
from zenav.common.bus import ZenohBus, undeclare_all
from zenav.common.client import Client, ZenavError
from zenav.tools import ros2_msgs as rm
from zenav.tools.rmw_zenoh import Endpoint, Wire, attachment, gid

log = logging.getLogger("zenav.ros2")

POSE, ODOMETRY, TF, GOAL = "pose", "odometry", "/tf", "goal_pose"
PUBLISHED = {
    POSE: ("geometry_msgs/msg/PoseWithCovarianceStamped", 10),
    ODOMETRY: ("nav_msgs/msg/Odometry", 10),
    TF: ("tf2_msgs/msg/TFMessage", 100),  # tf2's broadcaster depth
}
GOAL_TYPE = "geometry_msgs/msg/PoseStamped"
MOVE_TO_POSE = "nav/move_to_pose"
ODOM_KEEP = 500  # odom samples kept to find the one a pose is for (5 s at 100 Hz)
INBOX = 1000  # zenav messages waiting for the worker; more are dropped (counted)
WALL_SINCE = 1e9  # [s] a stack time after this (2001) is wall time; before, a sim clock's


class _Publisher:
    """One ROS publisher: its rmw_zenoh key, liveliness token, GID and sequence numbers."""

    def __init__(self, session: zenoh.Session, wire: Wire, ep: Endpoint, token: str) -> None:
        self.ros_type, self.key, self.gid, self.seq = ep.ros_type, wire.key(ep), gid(token), 0
        self._pub = session.declare_publisher(self.key, encoding=zenoh.Encoding.APPLICATION_CDR)
        self._token = session.liveliness().declare_token(token)

    def put(self, payload: bytes) -> None:
        self.seq += 1
        self._pub.put(payload, attachment=attachment(self.seq, time.time_ns(), self.gid))

    def undeclare(self) -> None:
        self._token.undeclare()
        self._pub.undeclare()


class Bridge:
    """Publishes one robot's pose and transforms to ROS 2 and forwards its goals; start() then stop()."""

    def __init__(self, bus: ZenohBus, robot: str, wire: Wire) -> None:
        self.bus, self.robot, self.wire = bus, robot, wire
        self.client = Client(robot, bus=bus)
        self.counts: dict[str, int] = dict.fromkeys((*PUBLISHED, "goals", "goals_refused", "dropped", "unstamped"), 0)
        self.offset: float | None = None  # [s] wall time minus stack time, from the clock topic
        self._odom: OrderedDict[float, rm.Pose2] = OrderedDict()
        self._inbox: queue.Queue[tuple[str, Any]] = queue.Queue(INBOX)
        self._goals: queue.Queue[bytes] = queue.Queue(1)
        self._stop = threading.Event()
        self._pubs: dict[str, _Publisher] = {}
        self._handles: list[Any] = []
        self._threads: list[threading.Thread] = []

    def keys(self) -> dict[str, str]:
        """ROS topic -> the Zenoh key it travels on."""
        out = {self.wire.name(name): pub.key for name, pub in self._pubs.items()}
        out[self.wire.name(GOAL)] = self.wire.key(self.wire.endpoint("MS", GOAL, GOAL_TYPE))
        return out

    def start(self) -> Bridge:
        """Declare the ROS node, its endpoints and the zenav subscriptions; start the threads."""
        session, zid = self.bus.session, str(self.bus.session.zid())
        self._handles.append(session.liveliness().declare_token(self.wire.node_token(zid)))
        for entity, (name, (ros_type, depth)) in enumerate(PUBLISHED.items(), start=1):
            ep = self.wire.endpoint("MP", name, ros_type, depth)
            self._pubs[name] = _Publisher(session, self.wire, ep, self.wire.token(zid, ep, entity))
        goal = self.wire.endpoint("MS", GOAL, GOAL_TYPE)
        self._handles.append(session.declare_subscriber(self.wire.key(goal), self._on_goal_sample))
        self._handles.append(session.liveliness().declare_token(self.wire.token(zid, goal, len(PUBLISHED) + 1)))
        for suffix in ("clock", "odom", "pose"):
            self.client.subscribe(suffix, functools.partial(self._enqueue, suffix))
        for target in (self._work, self._send_goals):
            thread = threading.Thread(target=target, name=f"ros2-{target.__name__.strip('_')}", daemon=True)
            thread.start()
            self._threads.append(thread)
        return self

    def stop(self) -> None:
        """Withdraw everything declared and end the threads (the bus stays the caller's)."""
        self._stop.set()
        for thread in self._threads:
            thread.join(timeout=5.0)
        self.client.close()
        undeclare_all([*self._pubs.values(), *self._handles])
        self._pubs.clear()
        self._handles.clear()

    # ------------------------------------------------------------ zenoh threads: enqueue only
    def _enqueue(self, suffix: str, msg: Any) -> None:
        try:
            self._inbox.put_nowait((suffix, msg))
        except queue.Full:
            self.counts["dropped"] += 1

    def _on_goal_sample(self, sample: zenoh.Sample) -> None:
        data = sample.payload.to_bytes()
        try:  # the newest goal wins
            self._goals.get_nowait()
        except queue.Empty:
            pass
        try:
            self._goals.put_nowait(data)
        except queue.Full:  # another goal came in between: it wins
            self.counts["dropped"] += 1

    # ------------------------------------------------------------ worker: convert and publish
    def _work(self) -> None:
        while not self._stop.is_set():
            try:
                suffix, msg = self._inbox.get(timeout=0.1)
            except queue.Empty:
                continue
            try:
                self._handle(suffix, msg)
            except Exception:
                log.exception("could not bridge %s", suffix)

    def _handle(self, suffix: str, msg: Any) -> None:
        if isinstance(msg, m.Clock):
            if msg.wall > 0.0:
                self.offset = msg.wall - msg.t
            return
        t = self.wall_time(msg.t)
        if t is None:
            self.counts["unstamped"] += 1
        elif isinstance(msg, m.Odom):
            self._odom[msg.t] = (msg.x, msg.y, msg.theta)
            while len(self._odom) > ODOM_KEEP:
                self._odom.popitem(last=False)
            types = self.wire.types()
            self._publish(TF, rm.tf_message(types, [rm.transform(types, t, rm.ODOM, rm.BASE, self._odom[msg.t])]))
        elif isinstance(msg, m.Pose):
            self._on_pose(msg, t)

    def wall_time(self, t: float) -> float | None:
        """The wall time [s] of stack time `t`; None while a sim clock's offset is unknown."""
        if t > WALL_SINCE:
            return t
        return None if self.offset is None else t + self.offset

    def _on_pose(self, pose: m.Pose, t: float) -> None:
        types = self.wire.types()
        self._publish(POSE, rm.pose_with_covariance(types, pose, t))
        self._publish(ODOMETRY, rm.odometry(types, pose, t))
        odom = self._odom.get(pose.t)
        if odom is not None:
            correction = rm.map_to_odom((pose.x, pose.y, pose.theta), odom)
            self._publish(TF, rm.tf_message(types, [rm.transform(types, t, rm.MAP, rm.ODOM, correction)]))

    def _publish(self, name: str, msg: Any) -> None:
        pub = self._pubs[name]
        pub.put(self.wire.serialize(msg, pub.ros_type))
        self.counts[name] += 1

    # ------------------------------------------------------------ goals
    def _send_goals(self) -> None:
        while not self._stop.is_set():
            try:
                data = self._goals.get(timeout=0.1)
            except queue.Empty:
                continue
            try:
                self._goal(data)
            except Exception:
                log.exception("could not forward a goal")

    def _goal(self, data: bytes) -> None:
        frame, x, y, heading = rm.goal(self.wire.deserialize(data, GOAL_TYPE))
        if frame.strip("/") not in ("", rm.MAP):
            self.counts["goals_refused"] += 1
            log.warning("goal in frame %r refused: goals are in %r", frame, rm.MAP)
            return
        request = {"x": x, "y": y, "theta": heading}
        try:
            reply = self.client.query(MOVE_TO_POSE, request)
        except ZenavError as e:
            self.counts["goals_refused"] += 1
            log.warning("%s %s refused: %s", MOVE_TO_POSE, request, e)
            return
        self.counts["goals"] += 1
        log.info("%s %s: goal %s %s", MOVE_TO_POSE, request, reply.goal_id, reply.state)
