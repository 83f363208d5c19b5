"""A ROS 2 action server on rmw_zenoh's action keys, driving one zenav goal per ROS goal.

rcl builds an action `<name>` from three services and two topics, all under `<name>/_action/`:
`send_goal`, `cancel_goal`, `get_result` (queryables here) and `feedback`, `status` (published).
What a goal means in zenav is the action's Mapping (tools/ros2_nav2.py: NavigateToPose,
FollowWaypoints); the protocol is here, the same for both:

- send_goal: the goal is accepted and the Mapping's zenav goal query sent; if the Mapping
  or the navigator refuses it (another frame, outside the field, no pose yet, ...), it is
  aborted at once with the reason in its result.
- feedback, for every `nav/state` of its zenav goal (the Mapping's Feedback).
- the result, when `nav/state` says the goal ended: `succeeded` SUCCEEDED, `cancelled`
  CANCELED (cancel_goal, `nav/stop`, or preempted by a newer goal), `aborted` ABORTED
  (the Mapping's Result, from the final state and the navigator's message).
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
from typing import Any, Protocol

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

ACCEPTED, EXECUTING, CANCELING, SUCCEEDED, CANCELED, ABORTED = 1, 2, 3, 4, 5, 6  # action_msgs/msg/GoalStatus
UNKNOWN_STATUS = 0
TERMINAL = (SUCCEEDED, CANCELED, ABORTED)
RESULTS: dict[str, int] = {GoalResult.SUCCEEDED: SUCCEEDED, GoalResult.CANCELLED: CANCELED, GoalResult.ABORTED: ABORTED}
CANCEL_NONE, CANCEL_UNKNOWN_GOAL, CANCEL_TERMINATED = 0, 2, 3  # action_msgs/srv/CancelGoal return codes
KEEP = 16  # finished goals kept for get_result and status
STOP = "nav/stop"
COUNTERS = ("action_goals", "action_refused", "action_bad_input")  # summed over the bridge's actions

Submit = Callable[[Callable[[], None]], None]  # runs a job on the command thread (or counts it dropped)


@dataclass
class Goal:
    """One ROS goal and the zenav goal it drives."""

    uuid: bytes
    stamp: float  # [s] wall time accepted
    request: Any = None  # the action's Goal message
    status: int = ACCEPTED
    zenav_id: int | None = None
    last: m.NavState | None = None  # the newest nav/state of its zenav goal
    data: Any = None  # what the Mapping keeps of the goal
    result: Any = None  # the action's Result message once ended
    waiting: list[zenoh.Query] = field(default_factory=list)  # get_result requests to answer when it ends


class Mapping(Protocol):
    """What one action's goals are in zenav."""

    name: str  # the action's ROS name, e.g. navigate_to_pose
    action: str  # its type, e.g. nav2_msgs/action/NavigateToPose

    def start(self, goal: Goal) -> tuple[str, dict[str, Any]]:
        """The zenav goal query and its request for `goal.request`; ValueError saying why it cannot be one."""

    def observe(self, msg: Any) -> None:
        """Another zenav message the bridge reads (a pose, a plan), in arrival order."""

    def feedback(self, goal: Goal, state: m.NavState) -> Any:
        """The action's Feedback for a running goal's nav/state."""

    def result(self, goal: Goal, status: int, message: str, state: m.NavState | None) -> Any:
        """The action's Result of an ended goal (its final nav/state; None when refused before it started)."""


class ActionServer:
    """The action server of one Mapping; counts go into the bridge's `counts`."""

    def __init__(self, node: Node, client: Client, submit: Submit, counts: dict[str, int], mapping: Mapping) -> None:
        self.node, self.client, self.submit, self.counts, self.mapping = node, client, submit, counts, mapping
        self.name, self.action = mapping.name, mapping.action
        rt.register(node.wire)
        self.types = node.wire.types()
        self._goals: OrderedDict[bytes, Goal] = OrderedDict()
        self._ended: OrderedDict[int, m.NavState] = OrderedDict()  # zenav goal id -> its final state
        self._lock = threading.Lock()
        base = f"{self.name}/_action/"
        self._feedback = node.publisher(base + "feedback", f"{self.action}_FeedbackMessage")
        self._status = node.publisher(base + "status", "action_msgs/msg/GoalStatusArray", depth=1, durability=TRANSIENT_LOCAL)
        for service, srv_type, job in (
            ("send_goal", f"{self.action}_SendGoal", self._send_goal),
            ("cancel_goal", rt.CANCEL, self._cancel_goal),
            ("get_result", f"{self.action}_GetResult", self._get_result),
        ):
            node.service(base + service, srv_type, functools.partial(self._on_query, job))
        for name in COUNTERS:
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
        req = self._decode(query, f"{self.action}_SendGoal_Request")
        if req is None:
            return
        goal = Goal(bytes(req.goal_id.uuid), time.time(), req.goal)
        with self._lock:
            self._goals[goal.uuid] = goal
        self.counts["action_goals"] += 1
        try:
            suffix, fields = self.mapping.start(goal)
            reply, reason = self.client.query(suffix, fields), ""
        except (ZenavError, ValueError) as e:
            reply, reason = None, str(e)
        response = self.types[f"{self.action}_SendGoal_Response"](accepted=True, stamp=rm.stamp(self.types, goal.stamp))
        self.node.reply(query, response, f"{self.action}_SendGoal_Response")
        if reply is None:
            self.counts["action_refused"] += 1
            log.warning("%s goal refused: %s", self.name, reason)
            self._finish(goal, ABORTED, reason, None)
            return
        log.info("%s goal: zenav goal %d %s", self.name, reply.goal_id, suffix)
        with self._lock:
            goal.zenav_id, goal.status = reply.goal_id, EXECUTING
            preempted = [g for g in self._goals.values() if g is not goal and g.status not in TERMINAL]
            ended = self._ended.get(reply.goal_id)
        for old in preempted:
            self._finish(old, CANCELED, "preempted by a newer goal", old.last)
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
                log.warning("%s cancel: %s failed: %s", self.name, STOP, e)

    def _get_result(self, query: zenoh.Query) -> None:
        req = self._decode(query, f"{self.action}_GetResult_Request")
        if req is None:
            return
        with self._lock:
            goal = self._goals.get(bytes(req.goal_id.uuid))
            if goal is not None and goal.status not in TERMINAL:
                goal.waiting.append(query)  # answered when it ends
                return
        if goal is None:
            self._answer(query, UNKNOWN_STATUS, self.mapping.result(Goal(b"", 0.0), UNKNOWN_STATUS, "", None))
        else:
            self._answer(query, goal.status, goal.result)

    # ------------------------------------------------------------ the navigator (worker thread)
    def on_message(self, msg: Any) -> None:
        """A zenav message the bridge read: a nav/state drives the goals; the Mapping sees the others."""
        if isinstance(msg, m.NavState):
            self.on_state(msg)
        else:
            self.mapping.observe(msg)

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
        goal.last = state
        if state.result is None:
            feedback = self.mapping.feedback(goal, state)
            self._feedback.put(self.types[f"{self.action}_FeedbackMessage"](goal_id=self._uuid(goal), feedback=feedback))
        else:
            self._finish(goal, RESULTS.get(state.result, ABORTED), state.message, state)

    # ------------------------------------------------------------ messages
    def _finish(self, goal: Goal, status: int, message: str, state: m.NavState | None) -> None:
        result = self.mapping.result(goal, status, message, state)
        with self._lock:
            if goal.status in TERMINAL:
                return
            goal.status, goal.result = status, result
            waiting, goal.waiting = goal.waiting, []
            while len(self._goals) > KEEP and next(iter(self._goals.values())).status in TERMINAL:
                self._goals.popitem(last=False)
        log.info("%s goal %s ended: status %d %s", self.name, goal.uuid.hex(), status, message)
        for query in waiting:
            self._answer(query, status, result)
        self._publish_status()

    def _answer(self, query: zenoh.Query, status: int, result: Any) -> None:
        response = self.types[f"{self.action}_GetResult_Response"](status=status, result=result)
        self.node.reply(query, response, f"{self.action}_GetResult_Response")

    def _uuid(self, goal: Goal) -> Any:
        return self.types["unique_identifier_msgs/msg/UUID"](uuid=np.frombuffer(goal.uuid, dtype=np.uint8).copy())

    def _info(self, goal: Goal) -> Any:
        return self.types["action_msgs/msg/GoalInfo"](goal_id=self._uuid(goal), stamp=rm.stamp(self.types, goal.stamp))

    def _publish_status(self) -> None:
        with self._lock:
            statuses = [self.types["action_msgs/msg/GoalStatus"](goal_info=self._info(g), status=g.status) for g in self._goals.values()]
        self._status.put(self.types["action_msgs/msg/GoalStatusArray"](status_list=statuses))
