"""zenav's topics as ROS 2 messages, stamped in wall time: what `zenav ros2` publishes and `zenav record --ros2` writes.

For each zenav message fed, the ROS messages it makes, by ROS topic (relative names; `/tf`
is global), following REP-105 (frames `map`, `odom`, `base_link`):

- `odom`: nav_msgs/Odometry of zenav's `odom`, in `odom` (what a ROS odometry source publishes);
- `odometry`: nav_msgs/Odometry of the fused `pose`, in `map`; `pose`: the same as
  geometry_msgs/PoseWithCovarianceStamped;
- `/tf`: `odom -> base_link` for every `odom`, and `map -> odom` for every `pose` whose odom
  sample (same t) came before it: the correction the localizer applied;
- `nav/state`: std_msgs/String, zenav's `nav/state` as JSON;
- `map`: nav_msgs/OccupancyGrid of the field the navigator plans on (its `field` topic: bounds
  and obstacles, 2 cm cells, 100 inside an obstacle, 0 free), sent when it changes (latched:
  transient local, depth 1, as a ROS map server's);
- `cmd_vel` (only when asked: the bridge takes `cmd_vel` in, so it must not send it out): geometry_msgs/Twist.

Stamps are wall time: a wall-clock stack's t is wall time already; a sim clock's t (under
WALL_SINCE) gets the offset its `clock` topic gives (wall - t), and messages before the
first tick are not converted (counted `unstamped`). No I/O.
"""

from __future__ import annotations

from collections import OrderedDict
from typing import Any

from zenav.common import messages as m
from zenav.tools import ros2_msgs as rm

POSE, ODOMETRY, ODOM, TF, NAV_STATE, CMD_VEL, MAP = "pose", "odometry", "odom", "/tf", "nav/state", "cmd_vel", "map"
TYPES = {  # ROS topic -> (type, the keep-last depth its publisher announces)
    POSE: ("geometry_msgs/msg/PoseWithCovarianceStamped", 10),
    ODOMETRY: ("nav_msgs/msg/Odometry", 10),
    ODOM: ("nav_msgs/msg/Odometry", 10),
    TF: ("tf2_msgs/msg/TFMessage", 100),  # tf2's broadcaster depth
    NAV_STATE: ("std_msgs/msg/String", 10),
    CMD_VEL: ("geometry_msgs/msg/Twist", 10),
    MAP: ("nav_msgs/msg/OccupancyGrid", 1),  # latched (LATCHED)
}
LATCHED = (MAP,)  # topics published transient local: a late subscriber gets the last message
BRIDGED = (POSE, ODOMETRY, ODOM, TF, NAV_STATE, MAP)  # what the bridge publishes
SUFFIXES = ("clock", "odom", "pose", "nav/state", "cmd_vel", "field")  # the zenav topics read
ODOM_KEEP = 500  # odom samples kept to find the one a pose is for (5 s at 100 Hz)
WALL_SINCE = 1e9  # [s] a stack time after this (2001) is wall time; before, a sim clock's

Out = list[tuple[str, Any]]  # (ROS topic, message)


class Converter:
    """Feed zenav messages in arrival order; get the ROS messages of the topics in `topics`."""

    def __init__(self, types: Any, topics: tuple[str, ...] = BRIDGED) -> None:
        self.types, self.topics = types, set(topics)
        self.offset: float | None = None  # [s] wall time minus stack time, from the clock topic
        self.unstamped = 0  # messages not converted: a sim clock's, before its first tick
        self._odom: OrderedDict[float, rm.Pose2] = OrderedDict()
        self._field: tuple[Any, ...] | None = None  # the field last sent as a map (bounds, obstacles)

    def wall_time(self, t: float) -> float | None:
        """The wall time [s] of stack time `t`; None while a sim clock's offset is unknown."""
        if t > WALL_SINCE:
            return t
        return None if self.offset is None else t + self.offset

    def feed(self, msg: Any) -> Out:
        """The ROS messages one zenav message makes (none for a clock tick)."""
        return [(topic, ros) for topic, ros in self._convert(msg) if topic in self.topics]

    def _convert(self, msg: Any) -> Out:
        if isinstance(msg, m.Clock):
            if msg.wall > 0.0:
                self.offset = msg.wall - msg.t
            return []
        if isinstance(msg, m.CmdVel):  # t = 0 is "now"
            return [(CMD_VEL, rm.twist_msg(self.types, msg.v, msg.omega))]
        if isinstance(msg, m.NavState):
            return [(NAV_STATE, rm.nav_state(self.types, msg))]
        t = self.wall_time(msg.t)
        if t is None:
            self.unstamped += 1
            return []
        if isinstance(msg, m.Odom):
            return self._on_odom(msg, t)
        if isinstance(msg, m.Pose):
            return self._on_pose(msg, t)
        if isinstance(msg, m.FieldMap):
            return self._on_field(msg, t)
        return []

    def _on_field(self, field: m.FieldMap, t: float) -> Out:
        shape = (field.enabled, field.x_min, field.x_max, field.y_min, field.y_max, repr(field.obstacles))
        if shape == self._field:
            return []
        grid = rm.occupancy_grid(self.types, field, t)
        if grid is None:
            return []
        self._field = shape
        return [(MAP, grid)]

    def _on_odom(self, odom: m.Odom, t: float) -> Out:
        xyt = (odom.x, odom.y, odom.theta)
        self._odom[odom.t] = xyt
        while len(self._odom) > ODOM_KEEP:
            self._odom.popitem(last=False)
        tf = rm.tf_message(self.types, [rm.transform(self.types, t, rm.ODOM, rm.BASE, xyt)])
        return [(ODOM, rm.odometry(self.types, odom, t, rm.ODOM)), (TF, tf)]

    def _on_pose(self, pose: m.Pose, t: float) -> Out:
        out = [(POSE, rm.pose_with_covariance(self.types, pose, t)), (ODOMETRY, rm.odometry(self.types, pose, t))]
        odom = self._odom.get(pose.t)
        if odom is not None:
            correction = rm.map_to_odom((pose.x, pose.y, pose.theta), odom)
            out.append((TF, rm.tf_message(self.types, [rm.transform(self.types, t, rm.MAP, rm.ODOM, correction)])))
        return out
