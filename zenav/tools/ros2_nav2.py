"""nav2's NavigateToPose and FollowWaypoints actions as zenav goals: the Mappings tools/ros2_action.py serves.

NavigateToPose (`navigate_to_pose`): the goal's pose (frame `map`) is `nav/move_to_pose`
(its yaw as theta). Feedback: the newest fused pose, the time since the goal started, the
navigator's ETA, the distance remaining. Result (Jazzy and later; Humble's has no fields):
`error_code` TIMEOUT when the move's timeout ran out, else UNKNOWN, and `error_msg` (the
navigator's message), NONE and "" on success.

FollowWaypoints (`follow_waypoints`): the poses (frame `map`) are the points of one
`nav/follow_path`, driven through without stopping; their headings are not used (follow_path
takes points only: the robot ends facing the way it came). Jazzy's and Kilted's `goal_index`
starts the first round at that pose and `number_of_loops` drives the poses that many more
times. Feedback: `current_waypoint`, the index in `poses` of the pose being approached (the
navigator's `next_point` over the path it drives, the detours it planned round obstacles
left out; nav/plan gives them). Result: on ABORTED the pose being approached is the missed
waypoint (Humble: its index; Jazzy: a MissedWaypoint; Kilted: a WaypointStatus FAILED),
`error_code` TASK_EXECUTOR_FAILED and `error_msg` the navigator's message; a goal refused
before it starts (a pose outside the field, another frame) has none missed, UNKNOWN and the
reason; CANCELED carries NONE and the reason in `error_msg`. No I/O.
"""

from __future__ import annotations

import time
from collections import OrderedDict
from dataclasses import dataclass
from typing import Any

from zenav.common import messages as m
from zenav.common.contract import Exit
from zenav.tools import ros2_msgs as rm
from zenav.tools import ros2_types as rt
from zenav.tools.ros2_action import ABORTED, CANCELED, SUCCEEDED, Goal

MOVE_TO_POSE, FOLLOW_PATH = "nav/move_to_pose", "nav/follow_path"
MAX_POINTS = 10_000  # the most points a nav/follow_path takes (FollowPath.points)
KEEP_PLANS = 16  # the plans (nav/plan) of the newest zenav goals


class NavigateToPose:
    """nav2_msgs/action/NavigateToPose as `nav/move_to_pose`."""

    name, action = "navigate_to_pose", rt.NAVIGATE

    def __init__(self, types: Any) -> None:
        self.types = types
        self._pose: m.Pose | None = None  # the newest fused pose (the feedback's current pose)

    def start(self, goal: Goal) -> tuple[str, dict[str, Any]]:
        frame, x, y, heading = rm.goal(goal.request.pose)
        if not rm.in_map(frame):
            raise ValueError(f"goal in frame {frame!r}: goals are in {rm.MAP!r}")
        return MOVE_TO_POSE, {"x": x, "y": y, "theta": heading}

    def observe(self, msg: Any) -> None:
        if isinstance(msg, m.Pose):
            self._pose = msg

    def feedback(self, goal: Goal, state: m.NavState) -> Any:
        pose = self._pose
        xyt = (0.0, 0.0, 0.0) if pose is None else (pose.x, pose.y, pose.theta)
        return self.types[f"{self.action}_Feedback"](
            current_pose=rm.pose_stamped(self.types, time.time(), xyt),
            navigation_time=rm.duration(self.types, state.elapsed),
            estimated_time_remaining=rm.duration(self.types, state.eta or 0.0),
            number_of_recoveries=0,
            distance_remaining=float(state.distance_remaining or 0.0),
        )

    def result(self, goal: Goal, status: int, message: str, state: m.NavState | None) -> Any:
        result_type = self.types[f"{self.action}_Result"]
        if "error_code" not in result_type.__dataclass_fields__:  # Humble: std_msgs/Empty result
            return result_type(result=self.types["std_msgs/msg/Empty"]())
        exit_ = None if state is None else state.exit
        if status == SUCCEEDED or not message and exit_ is None:
            return result_type(error_code=rt.NONE, error_msg="")
        return result_type(error_code=rt.TIMEOUT if exit_ == Exit.TIMEOUT else rt.UNKNOWN, error_msg=message)


@dataclass
class Waypoints:
    """What FollowWaypoints keeps of a goal: which pose each point of its path is."""

    order: list[int]  # index in `poses` of each point of the path sent
    path: list[tuple[float, float]]  # the points sent [m]
    current: int  # the index in `poses` of the pose being approached


class FollowWaypoints:
    """nav2_msgs/action/FollowWaypoints as one `nav/follow_path`."""

    name, action = "follow_waypoints", rt.FOLLOW

    def __init__(self, types: Any) -> None:
        self.types = types
        self._plans: OrderedDict[int, list[tuple[float, float]]] = OrderedDict()  # zenav goal id -> the points it drives

    def start(self, goal: Goal) -> tuple[str, dict[str, Any]]:
        req = goal.request
        order = path_order(len(req.poses), int(getattr(req, "goal_index", 0)), int(getattr(req, "number_of_loops", 0)))
        points = []
        for i, pose in enumerate(req.poses):
            frame, x, y, _ = rm.goal(pose)
            if not rm.in_map(frame):
                raise ValueError(f"poses[{i}] in frame {frame!r}: waypoints are in {rm.MAP!r}")
            points.append((x, y))
        goal.data = Waypoints(order, [points[i] for i in order], order[0])
        return FOLLOW_PATH, {"points": [list(p) for p in goal.data.path]}

    def observe(self, msg: Any) -> None:
        if isinstance(msg, m.Plan):
            self._plans[msg.goal_id] = [(p[0], p[1]) for p in msg.points]
            while len(self._plans) > KEEP_PLANS:
                self._plans.popitem(last=False)

    def _track(self, goal: Goal, state: m.NavState) -> Waypoints:
        wp: Waypoints = goal.data
        if state.next_point is not None:
            wp.current = wp.order[path_index(state.next_point, self._plans.get(state.goal_id), wp.path)]
        return wp

    def feedback(self, goal: Goal, state: m.NavState) -> Any:
        return self.types[f"{self.action}_Feedback"](current_waypoint=self._track(goal, state).current)

    def result(self, goal: Goal, status: int, message: str, state: m.NavState | None) -> Any:
        result_type = self.types[f"{self.action}_Result"]
        missed = self._track(goal, state).current if status == ABORTED and state is not None else None
        humble = "error_code" not in result_type.__dataclass_fields__
        if humble:
            return result_type(missed_waypoints=[] if missed is None else [missed])
        code = rt.TASK_EXECUTOR_FAILED if missed is not None else rt.WAYPOINTS_UNKNOWN
        if status in (SUCCEEDED, CANCELED) or not message:
            code = rt.NONE
        lost = [] if missed is None else [self._missed(goal, missed, message, state)]
        return result_type(missed_waypoints=lost, error_code=code, error_msg="" if status == SUCCEEDED else message)

    def _missed(self, goal: Goal, index: int, message: str, state: m.NavState | None) -> Any:
        """Jazzy's MissedWaypoint or Kilted's WaypointStatus of the pose `index` the goal failed at."""
        pose, code = goal.request.poses[index], rt.TIMEOUT if state is not None and state.exit == Exit.TIMEOUT else rt.UNKNOWN
        if "nav2_msgs/msg/WaypointStatus" in self.types:
            status = self.types["nav2_msgs/msg/WaypointStatus"]
            return status(waypoint_status=rt.WAYPOINT_FAILED, waypoint_index=index, waypoint_pose=pose, error_code=code, error_msg=message)
        return self.types["nav2_msgs/msg/MissedWaypoint"](index=index, goal=pose, error_code=code)


def path_order(count: int, goal_index: int = 0, loops: int = 0) -> list[int]:
    """The index in `poses` of each point of the path: from `goal_index` to the end, then all of them `loops` more
    times; ValueError when there is no pose, `goal_index` names none, or the path would be over MAX_POINTS."""
    if count == 0:
        raise ValueError("no poses: a FollowWaypoints goal needs one at least")
    if goal_index >= count:
        raise ValueError(f"goal_index {goal_index}: the goal has {count} poses")
    if count - goal_index + count * loops > MAX_POINTS:
        raise ValueError(f"{count} poses from goal_index {goal_index} with number_of_loops {loops} are over {MAX_POINTS} points")
    return list(range(goal_index, count)) + list(range(count)) * loops


def path_index(next_point: int, plan: list[tuple[float, float]] | None, path: list[tuple[float, float]]) -> int:
    """The index in `path` (the points sent) of the one approached when the navigator approaches `next_point` of
    `plan` (the points it drives: `path` with the detours it planned between them; None: not known, taken as `path`)."""
    if plan is not None:
        asked = 0  # the points of `path` passed, matched in order among the plan's
        for point in plan[:next_point]:
            if asked < len(path) and point == path[asked]:
                asked += 1
        return min(asked, len(path) - 1)
    return max(0, min(next_point, len(path) - 1))
