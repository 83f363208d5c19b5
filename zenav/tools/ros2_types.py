"""nav2_msgs' NavigateToPose and FollowWaypoints actions as each distro defines them, registered into a Wire's type store.

rosbags ships the common ROS 2 messages (geometry_msgs, nav_msgs, tf2_msgs, action_msgs,
unique_identifier_msgs) but not nav2_msgs: its goal, result and feedback are parsed here
from nav2's .action text of each distro (ros-navigation/navigation2, branches humble,
jazzy, kilted; constants left out, as they are from the type hash), and the types rcl
builds an action from are added beside them: `<Action>_SendGoal` and `_GetResult`
(services) and `_FeedbackMessage`. CancelGoal is action_msgs' own service.
"""

from __future__ import annotations

from rosbags.typesys import get_types_from_msg

from zenav.tools.rmw_zenoh import Wire

NAVIGATE = "nav2_msgs/action/NavigateToPose"
FOLLOW = "nav2_msgs/action/FollowWaypoints"
CANCEL = "action_msgs/srv/CancelGoal"

_FEEDBACK = """geometry_msgs/PoseStamped current_pose
builtin_interfaces/Duration navigation_time
builtin_interfaces/Duration estimated_time_remaining
int16 number_of_recoveries
float32 distance_remaining"""

# (goal, result, feedback) of nav2_msgs/action/NavigateToPose
NAVIGATE_TO_POSE = {
    "humble": ("geometry_msgs/PoseStamped pose\nstring behavior_tree", "std_msgs/Empty result", _FEEDBACK),
    "jazzy": ("geometry_msgs/PoseStamped pose\nstring behavior_tree", "uint16 error_code\nstring error_msg", _FEEDBACK),
}
NAVIGATE_TO_POSE["kilted"] = NAVIGATE_TO_POSE["jazzy"]

# (goal, result, feedback) of nav2_msgs/action/FollowWaypoints; Jazzy's result lists nav2_msgs/MissedWaypoint,
# Kilted's nav2_msgs/WaypointStatus (WAYPOINT_MSGS)
_WAYPOINTS_GOAL = "uint32 number_of_loops\nuint32 goal_index 0\ngeometry_msgs/PoseStamped[] poses"
_ERROR = "\nuint16 error_code\nstring error_msg"
FOLLOW_WAYPOINTS = {
    "humble": ("geometry_msgs/PoseStamped[] poses", "int32[] missed_waypoints", "uint32 current_waypoint"),
    "jazzy": (_WAYPOINTS_GOAL, "nav2_msgs/MissedWaypoint[] missed_waypoints" + _ERROR, "uint32 current_waypoint"),
    "kilted": (_WAYPOINTS_GOAL, "nav2_msgs/WaypointStatus[] missed_waypoints" + _ERROR, "uint32 current_waypoint"),
}
WAYPOINT_MSGS = {
    "humble": {},
    "jazzy": {"nav2_msgs/msg/MissedWaypoint": "uint32 index\ngeometry_msgs/PoseStamped goal\nuint16 error_code"},
    "kilted": {
        "nav2_msgs/msg/WaypointStatus": "uint8 waypoint_status\nuint32 waypoint_index\ngeometry_msgs/PoseStamped waypoint_pose\n"
        "uint16 error_code\nstring error_msg"
    },
}
WAYPOINT_FAILED = 3  # WaypointStatus.FAILED

CANCEL_GOAL = (
    "action_msgs/GoalInfo goal_info",
    "int8 return_code\naction_msgs/GoalInfo[] goals_canceling",
)

# nav2's result error codes: NavigateToPose's (kilted's constants; jazzy defines only NONE, with the same field)
NONE, UNKNOWN, TIMEOUT = 0, 9000, 9003
# FollowWaypoints' (jazzy and kilted)
WAYPOINTS_UNKNOWN, TASK_EXECUTOR_FAILED = 600, 601


def register_action(wire: Wire, action: str, goal: str, result: str, feedback: str) -> None:
    """Register an action's goal, result, feedback and the services and message rcl builds from them."""
    uuid = "unique_identifier_msgs/UUID goal_id"
    parts = {
        "Goal": goal,
        "Result": result,
        "Feedback": feedback,
        "SendGoal_Request": f"{uuid}\n{action}_Goal goal",
        "SendGoal_Response": "bool accepted\nbuiltin_interfaces/Time stamp",
        "GetResult_Request": uuid,
        "GetResult_Response": f"int8 status\n{action}_Result result",
        "FeedbackMessage": f"{uuid}\n{action}_Feedback feedback",
    }
    for part, text in parts.items():  # in order: each refers only to those before it
        wire.register(get_types_from_msg(text, f"{action}_{part}"))
    for service in ("SendGoal", "GetResult"):
        wire.register_service(f"{action}_{service}")


def register(wire: Wire) -> None:
    """Register NavigateToPose and FollowWaypoints (as `wire.distro` defines them) and action_msgs' CancelGoal service."""
    register_action(wire, NAVIGATE, *NAVIGATE_TO_POSE[wire.distro])
    for name, text in WAYPOINT_MSGS[wire.distro].items():
        wire.register(get_types_from_msg(text, name))
    register_action(wire, FOLLOW, *FOLLOW_WAYPOINTS[wire.distro])
    _register_service(wire, CANCEL, *CANCEL_GOAL)


def _register_service(wire: Wire, srv: str, request: str, response: str) -> None:
    # rosbags' .msg parser files a `pkg/srv/X` name under `pkg/srv/msg/X`: parse under a stand-in name, then file it right.
    for part, text in (("Request", request), ("Response", response)):
        stand_in = f"{srv}_{part}".replace("/srv/", "/action/")
        ((_, definition),) = get_types_from_msg(text, stand_in).items()
        wire.register({f"{srv}_{part}": definition})
    wire.register_service(srv)
