"""The contract's key expressions, and which message type travels on each."""

from __future__ import annotations

import re

from zenav.common import messages as m
from zenav.common.goalschema import GOALS
from zenav.common.roles import ALL as SERVICES

DEFAULT_CONNECT = "tcp/127.0.0.1:7447"  # the router the stack and its tools meet at (Zenoh's standard port)
_ROBOT_ID = re.compile(m.ROBOT_ID_PATTERN)

# Topic suffix (after zenav/<robot>/) -> message type.
TOPICS: dict[str, type[m.Topic]] = {
    "clock": m.Clock,
    "sim/truth": m.Truth,
    "sensors/encoders": m.Encoders,
    "sensors/imu": m.Imu,
    "sensors/compass": m.Compass,
    "vps/pose": m.VpsPose,
    "odom": m.Odom,
    "pose": m.Pose,
    "cmd_vel": m.CmdVel,
    "motors/wheels": m.Wheels,
    "nav/state": m.NavState,
    "nav/plan": m.Plan,
    "field": m.FieldMap,
    "motor/guard": m.GuardState,
    "localizer/fixes": m.Fix,
    "camera/onboard/frame": m.CameraFrame,
    **{f"diag/{s}": m.Diag for s in SERVICES},
}


def topic_type(suffix: str) -> type[m.Topic]:
    """The message type of a robot topic; a second instance's diag (diag/vps_onboard) is a Diag too. KeyError if none."""
    if suffix not in TOPICS and suffix.startswith("diag/") and suffix[5:].split("_", 1)[0] in SERVICES:
        return m.Diag
    return TOPICS[suffix]


# The robot's loop: the clock, the sensors (and the truth the simulated camera reads),
# the estimates and the commands; small periodic samples. Published at Zenoh's
# interactive-high priority, so on a link they overtake bulk data queued there (camera
# frames, a nav/state carrying a long path) and keep their order among themselves.
LOOP = frozenset(
    {"clock", "sim/truth", "sensors/encoders", "sensors/imu", "sensors/compass", "vps/pose", "odom", "pose", "cmd_vel", "motors/wheels"}
)

# Field-level topics: one sender serves every robot on the field, under zenav/field/ (not a robot's prefix).
FIELD = "field"
FIELD_TOPICS: dict[str, type[m.Topic]] = {
    "camera/frame": m.CameraFrame,
    "sim/body": m.Body,
    "robots": m.Body,
}

# Query suffix -> (request type, reply type).
QUERIES: dict[str, tuple[type[m.Request], type[m.Reply]]] = {
    **{spec.key: (spec.request, m.GoalReply) for spec in GOALS.values()},  # the goals (common/goalschema.py)
    "nav/stop": (m.Empty, m.StopReply),
    "nav/status": (m.Empty, m.StatusReply),
    "localizer/pose": (m.Empty, m.LocalizerPoseReply),
    "localizer/set_pose": (m.SetPose, m.PoseStamped),
    "sim/reset": (m.SimReset, m.PoseStamped),
    "time/sync": (m.Empty, m.ClockReply),
}


def check_robot_id(robot: str) -> str:
    """Return `robot` if it is a valid robot id, else raise ValueError."""
    if not _ROBOT_ID.match(robot):
        raise ValueError(f"robot id {robot!r} must match {m.ROBOT_ID_PATTERN}")
    return robot


def prefix(robot: str) -> str:
    """The key prefix of one robot: `zenav/<robot>`."""
    return f"zenav/{check_robot_id(robot)}"


def key(robot: str, suffix: str) -> str:
    """The full key expression of a contract suffix for one robot."""
    return f"{prefix(robot)}/{suffix}"


def alive(robot: str, service: str) -> str:
    """The liveliness token key of a service."""
    return key(robot, f"alive/{service}")


def split(key: str) -> tuple[str, str] | None:
    """`zenav/<robot>/<suffix>` -> (robot, suffix) (`field` for a field-level key); None for any other key."""
    parts = key.split("/", 2)
    if len(parts) != 3 or parts[0] != "zenav":
        return None
    return parts[1], parts[2]


def in_loop(key: str) -> bool:
    """Whether a full key is one of a robot's loop topics (`zenav/<robot>/<one of LOOP>`)."""
    where = split(key)
    return where is not None and where[1] in LOOP


def field_key(suffix: str) -> str:
    """The full key expression of a field-level topic: `zenav/field/<suffix>`."""
    return f"zenav/{FIELD}/{suffix}"
