"""A nav2_msgs/action/NavigateToPose action server on rmw_zenoh's action keys, driving zenav's `nav/move_to_pose`.

rcl builds an action `<name>` from three services and two topics, all under `<name>/_action/`:
`send_goal`, `cancel_goal`, `get_result` (queryables here) and `feedback`, `status` (published).

- send_goal: the goal's pose (frame `map`) becomes `nav/move_to_pose` (its yaw as theta). The
  goal is accepted; if the navigator refuses it (outside the field, no pose yet, ...) or its
  frame is not `map`, it is aborted at once with the reason as the result's `error_msg`.
- feedback, for every `nav/state` of the goal: the newest fused pose, the time since the goal
  started, the navigator's ETA, the distance remaining.
- the result, when `nav/state` says the goal ended: `succeeded` SUCCEEDED, `cancelled`
  CANCELED (cancel_goal, `nav/stop`, or preempted by a newer goal), `aborted` ABORTED; on
  Jazzy and later with nav2's `error_code` (TIMEOUT when the move's timeout ran out, else
  UNKNOWN) and `error_msg` (the navigator's message). Humble's result has no fields.
- get_result for a goal still running is answered when it ends.
- status: every accepted goal's status, on each change.

zenav runs one goal at a time: a new goal preempts the running one (CANCELED). Queries come
in on Zenoh's threads and are handed to the bridge's command thread (submit); nav/state
comes from its worker thread; a lock keeps the goals.
"""

from __future__ import annotations

import functools
import logging
import threading
import time
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import zenoh

from zenav.common import messages as m
from zenav.common.client import Client, ZenavError
from zenav.common.contract import GoalResult
from zenav.tools import ros2_msgs as rm
from zenav.tools import ros2_types as rt
from zenav.tools.rmw_zenoh import TRANSIENT_LOCAL
from zenav.tools.ros2_node import Node, request

log = logging.getLogger("zenav.ros2")

NAME = "navigate_to_pose"
ACCEPTED, EXECUTING, CANCELING, SUCCEEDED, CANCELED, ABORTED = 1, 2, 3, 4, 5, 6  # action_msgs/msg/GoalStatus
UNKNOWN_STATUS = 0
TERMINAL = (SUCCEEDED, CANCELED, ABORTED)
RESULTS: dict[str, int] = {GoalResult.SUCCEEDED: SUCCEEDED, GoalResult.CANCELLED: CANCELED, GoalResult.ABORTED: ABORTED}
CANCEL_NONE, CANCEL_UNKNOWN_GOAL, CANCEL_TERMINATED = 0, 2, 3  # action_msgs/srv/CancelGoal return codes
KEEP = 16  # finished goals kept for get_result and status
MOVE_TO_POSE, STOP = "nav/move_to_pose", "nav/stop"

Submit = Callable[[Callable[[], None]], None]  # runs a job on the command thread (or counts it dropped)


@dataclass
class Goal:
    """One ROS goal and the zenav goal it drives."""

    uuid: bytes
    stamp: float  # [s] wall time accepted
    status: int = ACCEPTED
    zenav_id: int | None = None
    result: Any = None  # the action's Result message once ended
    waiting: list[zenoh.Query] = field(default_factory=list)  # get_result requests to answer when it ends


class NavigateToPose:
    """The action server; counts go into the bridge's `counts`."""

    def __init__(self, node: Node, client: Client, submit: Submit, counts: dict[str, int]) -> None:
        self.node, self.client, self.submit, self.counts = node, client, submit, counts
        wire = node.wire
        rt.register(wire)
        self.types = wire.types()
        self._goals: OrderedDict[bytes, Goal] = OrderedDict()
        self._ended: OrderedDict[int, m.NavState] = OrderedDict()  # zenav goal id -> its final state
        self._pose: m.Pose | None = None
        self._lock = threading.Lock()
        base = f"{NAME}/_action/"
        self._feedback = node.publisher(base + "feedback", f"{rt.NAVIGATE}_FeedbackMessage")
        self._status = node.publisher(base + "status", "action_msgs/msg/GoalStatusArray", depth=1, durability=TRANSIENT_LOCAL)
        for service, srv_type, job in (
            ("send_goal", f"{rt.NAVIGATE}_SendGoal", self._send_goal),
            ("cancel_goal", rt.CANCEL, self._cancel_goal),
            ("get_result", f"{rt.NAVIGATE}_GetResult", self._get_result),
        ):
            node.service(base + service, srv_type, functools.partial(self._on_query, job))
        for name in ("action_goals", "action_refused", "action_bad_input"):
            counts.setdefault(name, 0)

    def _on_query(self, job: Callable[[zenoh.Query], None], query: zenoh.Query) -> None:
        self.submit(functools.partial(job, query))

    def close(self) -> None:
        """Answer nothing more: drop the get_result requests still held."""
        with self._lock:
            for goal in self._goals.values():
                for query in goal.waiting:
                    query.drop()
                goal.waiting.clear()

    # ------------------------------------------------------------ requests (command thread)
    def _decode(self, query: zenoh.Query, ros_type: str) -> Any:
        try:
            return self.node.wire.deserialize(request(query), ros_type)
        except Exception as e:  # rosbags raises several kinds on bad CDR
            self.counts["action_bad_input"] += 1
            log.warning("%s: malformed %s request dropped: %s", query.key_expr, ros_type, e)
            query.reply_err(f"malformed {ros_type}: {e}".encode())
            query.drop()
            return None

    def _send_goal(self, query: zenoh.Query) -> None:
        req = self._decode(query, f"{rt.NAVIGATE}_SendGoal_Request")
        if req is None:
            return
        goal = Goal(bytes(req.goal_id.uuid), time.time())
        with self._lock:
            self._goals[goal.uuid] = goal
        self.counts["action_goals"] += 1
        try:
            frame, x, y, heading = rm.goal(req.goal.pose)
            reply = None if not rm.in_map(frame) else self.client.query(MOVE_TO_POSE, {"x": x, "y": y, "theta": heading})
            reason = f"goal in frame {frame!r}: goals are in {rm.MAP!r}" if reply is None else ""
        except (ZenavError, ValueError) as e:
            reply, reason = None, str(e)
        response = self.types[f"{rt.NAVIGATE}_SendGoal_Response"](accepted=True, stamp=rm.stamp(self.types, goal.stamp))
        self.node.reply(query, response, f"{rt.NAVIGATE}_SendGoal_Response")
        if reply is None:
            self.counts["action_refused"] += 1
            log.warning("%s goal refused: %s", NAME, reason)
            self._finish(goal, ABORTED, reason, None)
            return
        log.info("%s goal: zenav goal %d to (%.3f, %.3f, %.3f)", NAME, reply.goal_id, x, y, heading)
        with self._lock:
            goal.zenav_id, goal.status = reply.goal_id, EXECUTING
            preempted = [g for g in self._goals.values() if g is not goal and g.status not in TERMINAL]
            ended = self._ended.get(reply.goal_id)
        for old in preempted:
            self._finish(old, CANCELED, "preempted by a newer goal", None)
        self._publish_status()
        if ended is not None:  # it ended before its id came back
            self.on_state(ended)

    def _cancel_goal(self, query: zenoh.Query) -> None:
        req = self._decode(query, f"{rt.CANCEL}_Request")
        if req is None:
            return
        uuid, before = bytes(req.goal_info.goal_id.uuid), req.goal_info.stamp.sec + req.goal_info.stamp.nanosec * 1e-9
        with self._lock:
            known = self._goals.get(uuid)
            targets = [
                g
                for g in self._goals.values()
                if g.status in (ACCEPTED, EXECUTING)
                and (g.uuid == uuid or not any(uuid) and before == 0 or 0 < before and g.stamp <= before)
            ]
            for g in targets:
                g.status = CANCELING
            running = any(g.zenav_id is not None for g in targets)
        code = CANCEL_NONE if targets else CANCEL_TERMINATED if known is not None else CANCEL_UNKNOWN_GOAL
        infos = [self._info(g) for g in targets]
        response = self.types[f"{rt.CANCEL}_Response"](return_code=code, goals_canceling=infos)
        self.node.reply(query, response, f"{rt.CANCEL}_Response")
        if targets:
            self._publish_status()
        if running:
            try:
                self.client.query(STOP)
            except ZenavError as e:
                log.warning("%s cancel: %s failed: %s", NAME, STOP, e)

    def _get_result(self, query: zenoh.Query) -> None:
        req = self._decode(query, f"{rt.NAVIGATE}_GetResult_Request")
        if req is None:
            return
        with self._lock:
            goal = self._goals.get(bytes(req.goal_id.uuid))
            if goal is not None and goal.status not in TERMINAL:
                goal.waiting.append(query)  # answered when it ends
                return
        status, result = (UNKNOWN_STATUS, self._result("", None)) if goal is None else (goal.status, goal.result)
        self._answer(query, status, result)

    # ------------------------------------------------------------ the navigator (worker thread)
    def on_pose(self, pose: m.Pose) -> None:
        """The newest fused pose (the feedback's current pose)."""
        self._pose = pose

    def on_state(self, state: m.NavState) -> None:
        """A nav/state: feedback for the goal it is of, or its end."""
        with self._lock:
            goal = next((g for g in self._goals.values() if g.zenav_id == state.goal_id and g.status not in TERMINAL), None)
            if state.result is not None:
                self._ended[state.goal_id] = state
                while len(self._ended) > KEEP:
                    self._ended.popitem(last=False)
        if goal is None:
            return
        if state.result is None:
            self._feedback.put(self._feedback_message(goal, state))
        else:
            self._finish(goal, RESULTS.get(state.result, ABORTED), state.message, state.exit)

    # ------------------------------------------------------------ messages
    def _finish(self, goal: Goal, status: int, message: str, exit_: str | None) -> None:
        with self._lock:
            if goal.status in TERMINAL:
                return
            goal.status, goal.result = status, self._result(message, exit_) if status != SUCCEEDED else self._result("", None)
            waiting, goal.waiting = goal.waiting, []
            while len(self._goals) > KEEP and next(iter(self._goals.values())).status in TERMINAL:
                self._goals.popitem(last=False)
        log.info("%s goal %s ended: status %d %s", NAME, goal.uuid.hex(), status, message)
        for query in waiting:
            self._answer(query, status, goal.result)
        self._publish_status()

    def _result(self, message: str, exit_: str | None) -> Any:
        result_type = self.types[f"{rt.NAVIGATE}_Result"]
        if "error_code" not in result_type.__dataclass_fields__:  # Humble: std_msgs/Empty result
            return result_type(result=self.types["std_msgs/msg/Empty"]())
        code = rt.NONE if not message and exit_ is None else rt.TIMEOUT if exit_ == "timeout" else rt.UNKNOWN
        return result_type(error_code=code, error_msg=message)

    def _answer(self, query: zenoh.Query, status: int, result: Any) -> None:
        response = self.types[f"{rt.NAVIGATE}_GetResult_Response"](status=status, result=result)
        self.node.reply(query, response, f"{rt.NAVIGATE}_GetResult_Response")

    def _uuid(self, goal: Goal) -> Any:
        return self.types["unique_identifier_msgs/msg/UUID"](uuid=np.frombuffer(goal.uuid, dtype=np.uint8).copy())

    def _info(self, goal: Goal) -> Any:
        return self.types["action_msgs/msg/GoalInfo"](goal_id=self._uuid(goal), stamp=rm.stamp(self.types, goal.stamp))

    def _feedback_message(self, goal: Goal, state: m.NavState) -> Any:
        pose = self._pose
        xyt = (0.0, 0.0, 0.0) if pose is None else (pose.x, pose.y, pose.theta)
        feedback = self.types[f"{rt.NAVIGATE}_Feedback"](
            current_pose=rm.pose_stamped(self.types, time.time(), xyt),
            navigation_time=rm.duration(self.types, state.elapsed),
            estimated_time_remaining=rm.duration(self.types, state.eta or 0.0),
            number_of_recoveries=0,
            distance_remaining=float(state.distance_remaining or 0.0),
        )
        return self.types[f"{rt.NAVIGATE}_FeedbackMessage"](goal_id=self._uuid(goal), feedback=feedback)

    def _publish_status(self) -> None:
        with self._lock:
            statuses = [self.types["action_msgs/msg/GoalStatus"](goal_info=self._info(g), status=g.status) for g in self._goals.values()]
        self._status.put(self.types["action_msgs/msg/GoalStatusArray"](status_list=statuses))
