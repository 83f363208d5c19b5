"""nav2_msgs' NavigateToPose action as each distro defines it, registered into a Wire's type store.

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

CANCEL_GOAL = (
    "action_msgs/GoalInfo goal_info",
    "int8 return_code\naction_msgs/GoalInfo[] goals_canceling",
)

# nav2's result error codes (kilted's constants; jazzy defines only NONE, with the same field)
NONE, UNKNOWN, TIMEOUT = 0, 9000, 9003


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
    """Register NavigateToPose (as `wire.distro` defines it) and action_msgs' CancelGoal service."""
    register_action(wire, NAVIGATE, *NAVIGATE_TO_POSE[wire.distro])
    _register_service(wire, CANCEL, *CANCEL_GOAL)


def _register_service(wire: Wire, srv: str, request: str, response: str) -> None:
    # rosbags' .msg parser files a `pkg/srv/X` name under `pkg/srv/msg/X`: parse under a stand-in name, then file it right.
    for part, text in (("Request", request), ("Response", response)):
        stand_in = f"{srv}_{part}".replace("/srv/", "/action/")
        ((_, definition),) = get_types_from_msg(text, stand_in).items()
        wire.register({f"{srv}_{part}": definition})
    wire.register_service(srv)
