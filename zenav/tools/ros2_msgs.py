"""zenav's poses as ROS 2 messages (rosbags message classes), and ROS goals back: no I/O.

Frames follow REP-105: `map` (zenav's map frame, where `pose` lives), `odom` (where
`odom` lives) and `base_link` (the robot). map -> odom is the correction the localizer
has applied: the pose composed with the inverse of the odometry at the same t.
"""

from __future__ import annotations

import math
from typing import Any

import msgspec
import numpy as np

from zenav.common import field as fd
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


def twist_msg(types: Any, v: float, omega: float) -> Any:
    """geometry_msgs/Twist of a forward speed [m/s] and a yaw rate [rad/s]."""
    vec = types["geometry_msgs/msg/Vector3"]
    return types["geometry_msgs/msg/Twist"](linear=vec(x=v, y=0.0, z=0.0), angular=vec(x=0.0, y=0.0, z=omega))


def odometry(types: Any, pose: m.Pose | m.Odom, t: float, frame: str = MAP) -> Any:
    """nav_msgs/Odometry of a pose in `frame` (the fused pose: map; odometry: odom), twist in base_link, stamped `t` [s]."""
    twist = twist_msg(types, pose.v, pose.omega)
    return types["nav_msgs/msg/Odometry"](
        header=header(types, t, frame),
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


def pose_stamped(types: Any, t: float, xyt: Pose2) -> Any:
    """geometry_msgs/PoseStamped in map, stamped `t` [s]."""
    return types["geometry_msgs/msg/PoseStamped"](header=header(types, t, MAP), pose=_pose(types, *xyt))


def duration(types: Any, seconds: float) -> Any:
    """builtin_interfaces/Duration of `seconds` (>= 0)."""
    ns = max(round(seconds * 1e9), 0)
    return types["builtin_interfaces/msg/Duration"](sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def nav_state(types: Any, state: m.NavState) -> Any:
    """std_msgs/String holding the navigator's state as zenav's JSON (the NavState fields)."""
    return types["std_msgs/msg/String"](data=msgspec.json.encode(state).decode())


def _finite(*values: float) -> tuple[float, ...]:
    if not all(math.isfinite(v) for v in values):
        raise ValueError(f"values not finite: {values}")
    return values


def goal(msg: Any) -> tuple[str, float, float, float]:
    """(frame, x [m], y [m], heading [rad]) of a geometry_msgs/PoseStamped (a goal) or of the pose of a
    PoseWithCovarianceStamped (an initial pose); ValueError if not finite."""
    p = msg.pose.pose if hasattr(msg.pose, "covariance") else msg.pose
    x, y, heading = _finite(float(p.position.x), float(p.position.y), yaw(p.orientation))
    return msg.header.frame_id, x, y, heading


def velocity(msg: Any) -> tuple[float, float]:
    """(forward speed [m/s], yaw rate [rad/s]) of a geometry_msgs/Twist or TwistStamped; ValueError if not finite.
    The other axes (sideways, up, roll, pitch) a differential drive cannot follow are ignored."""
    tw = msg.twist if hasattr(msg, "twist") else msg
    v, omega = _finite(float(tw.linear.x), float(tw.angular.z))
    return v, omega


def in_map(frame: str) -> bool:
    """Whether a message's frame is the map (or left empty)."""
    return frame.strip("/") in ("", MAP)


MAP_RESOLUTION = 0.02  # [m] a cell of the field's OccupancyGrid
MAP_PAD = 0.5  # [m] round the obstacles, when the field has no bounds
FREE, OCCUPIED = 0, 100


def field_cells(field: m.FieldMap, resolution: float = MAP_RESOLUTION) -> tuple[float, float, np.ndarray] | None:
    """The field as a grid: (x, y) of its lower-left corner [m] and rows of cells (row 0 at y, FREE or
    OCCUPIED: a cell whose centre is inside an obstacle); None when the field has neither bounds nor obstacles."""
    shapes = [_shape(o) for o in field.obstacles]
    if field.enabled:
        x0, x1, y0, y1 = field.x_min, field.x_max, field.y_min, field.y_max
    elif shapes:
        boxes = np.array([s.bounds() for s in shapes])  # (x_min, y_min, x_max, y_max) each
        x0, y0 = boxes[:, 0].min() - MAP_PAD, boxes[:, 1].min() - MAP_PAD
        x1, y1 = boxes[:, 2].max() + MAP_PAD, boxes[:, 3].max() + MAP_PAD
    else:
        return None
    cols, rows = max(1, math.ceil((x1 - x0) / resolution - 1e-9)), max(1, math.ceil((y1 - y0) / resolution - 1e-9))
    xs, ys = np.meshgrid(x0 + (np.arange(cols) + 0.5) * resolution, y0 + (np.arange(rows) + 0.5) * resolution)
    inside = np.zeros((rows, cols), dtype=bool)
    for s in shapes:
        inside |= _inside(s, xs, ys)
    return x0, y0, np.where(inside, OCCUPIED, FREE).astype(np.int8)


def occupancy_grid(types: Any, field: m.FieldMap, t: float, resolution: float = MAP_RESOLUTION) -> Any:
    """nav_msgs/OccupancyGrid of the field (frame `map`, stamped `t` [s]); None when there is nothing to draw."""
    grid = field_cells(field, resolution)
    if grid is None:
        return None
    x0, y0, cells = grid
    rows, cols = cells.shape
    info = types["nav_msgs/msg/MapMetaData"](
        map_load_time=stamp(types, t), resolution=resolution, width=cols, height=rows, origin=_pose(types, x0, y0, 0.0)
    )
    return types["nav_msgs/msg/OccupancyGrid"](header=header(types, t, MAP), info=info, data=cells.reshape(-1))


def _shape(obstacle: dict[str, Any]) -> fd.Shape:
    name = str(obstacle.get("name", "obstacle"))
    return fd.circle_shape(name, obstacle["circle"]) if "circle" in obstacle else fd.polygon_shape(name, obstacle["polygon"])


def _inside(shape: fd.Shape, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """Which points (xs, ys) lie inside `shape` (even-odd rule for a polygon)."""
    if shape.circle is not None:
        cx, cy, r = shape.circle
        return np.hypot(xs - cx, ys - cy) < r
    inside = np.zeros(xs.shape, dtype=bool)
    pts = shape.polygon
    for (ax, ay), (bx, by) in zip(pts, pts[1:] + pts[:1]):
        crosses = (ay > ys) != (by > ys)
        with np.errstate(divide="ignore", invalid="ignore"):
            x_at = ax + (ys - ay) * (bx - ax) / (by - ay)
        inside ^= crosses & (xs < x_at)
    return inside
