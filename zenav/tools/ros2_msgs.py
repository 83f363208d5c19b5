"""zenav's poses as ROS 2 messages (rosbags message classes), and ROS goals back: no I/O.

Frames follow REP-105: `map` (zenav's map frame, where `pose` lives), `odom` (where
`odom` lives) and `base_link` (the robot). map -> odom is the correction the localizer
has applied: the pose composed with the inverse of the odometry at the same t.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from zenav.common import messages as m
from zenav.common.geometry import wrap_angle

MAP, ODOM, BASE = "map", "odom", "base_link"
POSE_AXES = (0, 1, 5)  # the rows of (x, y, theta) in a ROS 6x6 pose covariance (x, y, z, roll, pitch, yaw)

Pose2 = tuple[float, float, float]  # (x [m], y [m], theta [rad])


def stamp(types: Any, t: float) -> Any:
    """builtin_interfaces/Time of `t` [s]."""
    ns = round(t * 1e9)
    return types["builtin_interfaces/msg/Time"](sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def header(types: Any, t: float, frame: str) -> Any:
    """std_msgs/Header at `t` [s] in `frame`."""
    return types["std_msgs/msg/Header"](stamp=stamp(types, t), frame_id=frame)


def quaternion(types: Any, theta: float) -> Any:
    """The rotation by `theta` [rad] about z."""
    return types["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=math.sin(theta / 2), w=math.cos(theta / 2))


def yaw(q: Any) -> float:
    """The heading [rad] of a quaternion (its rotation about z)."""
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def covariance6(cov: tuple[float, ...]) -> np.ndarray:
    """A ROS 6x6 pose covariance (row-major, 36) from zenav's 3x3 of (x, y, theta); other axes 0."""
    out = np.zeros((6, 6))
    out[np.ix_(POSE_AXES, POSE_AXES)] = np.reshape(cov, (3, 3))
    return out.reshape(36)


def _pose(types: Any, x: float, y: float, theta: float) -> Any:
    point = types["geometry_msgs/msg/Point"](x=x, y=y, z=0.0)
    return types["geometry_msgs/msg/Pose"](position=point, orientation=quaternion(types, theta))


def pose_with_covariance(types: Any, pose: m.Pose, t: float) -> Any:
    """geometry_msgs/PoseWithCovarianceStamped of the fused pose, stamped `t` [s]."""
    pwc = types["geometry_msgs/msg/PoseWithCovariance"](pose=_pose(types, pose.x, pose.y, pose.theta), covariance=covariance6(pose.cov))
    return types["geometry_msgs/msg/PoseWithCovarianceStamped"](header=header(types, t, MAP), pose=pwc)


def odometry(types: Any, pose: m.Pose, t: float) -> Any:
    """nav_msgs/Odometry of the fused pose (map frame), twist in base_link, stamped `t` [s]."""
    vec = types["geometry_msgs/msg/Vector3"]
    twist = types["geometry_msgs/msg/Twist"](linear=vec(x=pose.v, y=0.0, z=0.0), angular=vec(x=0.0, y=0.0, z=pose.omega))
    return types["nav_msgs/msg/Odometry"](
        header=header(types, t, MAP),
        child_frame_id=BASE,
        pose=types["geometry_msgs/msg/PoseWithCovariance"](pose=_pose(types, pose.x, pose.y, pose.theta), covariance=covariance6(pose.cov)),
        twist=types["geometry_msgs/msg/TwistWithCovariance"](twist=twist, covariance=np.zeros(36)),
    )


def map_to_odom(pose: Pose2, odom: Pose2) -> Pose2:
    """The map -> odom transform: `pose` (map) composed with the inverse of `odom` (odom frame) at the same t."""
    dth = wrap_angle(pose[2] - odom[2])
    c, s = math.cos(dth), math.sin(dth)
    return pose[0] - (c * odom[0] - s * odom[1]), pose[1] - (s * odom[0] + c * odom[1]), dth


def transform(types: Any, t: float, parent: str, child: str, xyt: Pose2) -> Any:
    """geometry_msgs/TransformStamped parent -> child, stamped `t` [s]."""
    tr = types["geometry_msgs/msg/Vector3"](x=xyt[0], y=xyt[1], z=0.0)
    return types["geometry_msgs/msg/TransformStamped"](
        header=header(types, t, parent),
        child_frame_id=child,
        transform=types["geometry_msgs/msg/Transform"](translation=tr, rotation=quaternion(types, xyt[2])),
    )


def tf_message(types: Any, transforms: list[Any]) -> Any:
    """tf2_msgs/TFMessage of some transforms."""
    return types["tf2_msgs/msg/TFMessage"](transforms=transforms)


def goal(msg: Any) -> tuple[str, float, float, float]:
    """(frame, x [m], y [m], heading [rad]) of a geometry_msgs/PoseStamped goal."""
    p = msg.pose
    return msg.header.frame_id, float(p.position.x), float(p.position.y), yaw(p.orientation)
