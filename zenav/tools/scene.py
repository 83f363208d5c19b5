"""What the live view draws, as Foxglove messages built from the robot's contract messages.

Pure: no server, no clock. `update()` takes one message and returns the Foxglove
messages to show at once (poses, the map->base_link transform, log lines on events);
`scene()` returns the whole SceneUpdate (trails, covariance ellipse, VPS fixes, goal,
path, navigator state), which `feed()` adds once per period rather than per message.
The live view (tools/view.py) and the recorder (tools/record.py) both feed a Scene,
so a recording holds the channels the live view shows (VIZ_TYPES).
Everything is in the `map` frame; odom is drawn as it is (its frame starts where the
robot starts). Stamps are the arrival wall time, the live timeline Foxglove shows.
"""

from __future__ import annotations

import math
from collections import deque
from typing import Any

import numpy as np
from foxglove import messages as fm

from zenav.common import messages as m
from zenav.common.contract import GoalResult

FRAME = "map"
ROBOT_FRAME = "base_link"  # child of map, at the fused pose
TRAIL_STEP = 0.01  # [m] a trail gets a new point when the robot moved this far
TRAIL_POINTS = 3000  # points kept per trail (30 m of path)
FIXES_KEPT = 300  # VPS fixes drawn
ELLIPSE_SIGMA = math.sqrt(5.991)  # 95 % of a 2-D Gaussian lies inside this many sigmas
SCENE_PERIOD = 0.1  # [s] between two SceneUpdates of the live view
NS = 1_000_000_000  # nanoseconds per second

VIZ_TYPES: dict[str, type] = {  # view topic suffix (under zenav/<robot>/) -> Foxglove message type
    "viz/truth": fm.PoseInFrame,
    "viz/odom": fm.PoseInFrame,
    "viz/pose": fm.PoseInFrame,
    "viz/tf": fm.FrameTransforms,
    "viz/scene": fm.SceneUpdate,
    "viz/log": fm.Log,
}

COLOURS = {  # r, g, b, a
    "truth": (0.1, 0.75, 0.2, 1.0),
    "odom": (1.0, 0.5, 0.05, 1.0),
    "pose": (0.12, 0.47, 0.9, 1.0),
    "ellipse": (0.12, 0.47, 0.9, 0.3),
    "fix": (0.6, 0.3, 0.75, 0.8),
    "fix_accepted": (0.1, 0.75, 0.2, 0.8),
    "fix_rejected": (0.9, 0.1, 0.1, 0.9),
    "goal": (0.95, 0.8, 0.1, 0.8),
    "plan": (0.95, 0.55, 0.1, 0.9),
    "obstacle": (0.85, 0.2, 0.2, 1.0),
    "edge": (0.7, 0.7, 0.7, 1.0),
    "text": (1.0, 1.0, 1.0, 1.0),
}


def colour(name: str) -> fm.Color:
    """A named colour of COLOURS."""
    r, g, b, a = COLOURS[name]
    return fm.Color(r=r, g=g, b=b, a=a)


def timestamp(ns: int) -> fm.Timestamp:
    """Nanoseconds since the epoch as a Foxglove timestamp."""
    return fm.Timestamp(sec=ns // NS, nsec=ns % NS)


def yaw(theta: float) -> fm.Quaternion:
    """The rotation by `theta` [rad] about z."""
    return fm.Quaternion(x=0.0, y=0.0, z=math.sin(theta / 2), w=math.cos(theta / 2))


def pose3(x: float, y: float, theta: float = 0.0, z: float = 0.0) -> fm.Pose:
    """A planar pose [m, rad] as a Foxglove 3D pose."""
    return fm.Pose(position=fm.Vector3(x=x, y=y, z=z), orientation=yaw(theta))


def ellipse(cov: tuple[float, ...], sigmas: float = ELLIPSE_SIGMA) -> tuple[float, float, float] | None:
    """(semi-major [m], semi-minor [m], angle of the major axis [rad]) of the xy block of a 3x3 cov."""
    xy = np.array([[cov[0], cov[1]], [cov[3], cov[4]]])
    if not np.all(np.isfinite(xy)) or np.allclose(xy, 0.0):
        return None
    vals, vecs = np.linalg.eigh((xy + xy.T) / 2)
    major = vecs[:, 1]
    return sigmas * math.sqrt(max(vals[1], 0.0)), sigmas * math.sqrt(max(vals[0], 0.0)), math.atan2(major[1], major[0])


def goal_points(goal: dict[str, Any] | None) -> list[tuple[float, float]]:
    """The map points of a navigator goal: its path (`points`), or its target (`x`, `y`)."""
    if not goal:
        return []
    if isinstance(goal.get("points"), list):
        return [(float(p[0]), float(p[1])) for p in goal["points"] if isinstance(p, (list, tuple)) and len(p) >= 2]
    if isinstance(goal.get("x"), (int, float)) and isinstance(goal.get("y"), (int, float)):
        return [(float(goal["x"]), float(goal["y"]))]
    return []


class Trail:
    """Positions a robot went through, a point every TRAIL_STEP metres."""

    def __init__(self) -> None:
        self.points: deque[tuple[float, float]] = deque(maxlen=TRAIL_POINTS)

    def add(self, x: float, y: float) -> None:
        """Take a position [m]; kept if TRAIL_STEP away from the last one."""
        if not self.points or math.hypot(x - self.points[-1][0], y - self.points[-1][1]) >= TRAIL_STEP:
            self.points.append((x, y))


class Scene:
    """The state of one robot's view, fed message by message."""

    def __init__(self, robot: str, period: float = SCENE_PERIOD) -> None:
        self.robot = robot
        self.period = period  # [s] between two SceneUpdates from feed()
        self._scene_ns: int | None = None  # when feed() last added one
        self.trails = {"truth": Trail(), "odom": Trail(), "pose": Trail()}
        self.pose: m.Pose | None = None
        self.nav: m.NavState | None = None
        self.fixes: deque[list[Any]] = deque(maxlen=FIXES_KEPT)  # [t, x, y, accepted or None]
        self.status: dict[str, str] = {}  # service -> diag status
        self.field: m.FieldMap | None = None
        self.plan: m.Plan | None = None

    def feed(self, suffix: str, msg: Any, ns: int) -> list[tuple[str, Any]]:
        """update(), plus the whole SceneUpdate when `period` has passed since the last one."""
        out = self.update(suffix, msg, ns)
        if self._scene_ns is None or ns - self._scene_ns >= self.period * NS:
            self._scene_ns = ns
            out.append(("viz/scene", self.scene(ns)))
        return out

    def update(self, suffix: str, msg: Any, ns: int) -> list[tuple[str, Any]]:
        """Take one contract message; return (view topic suffix, Foxglove message) pairs to log now."""
        stamp = timestamp(ns)
        if suffix in ("sim/truth", "odom", "pose"):
            name = suffix.rsplit("/", 1)[-1]
            self.trails[name].add(msg.x, msg.y)
            out: list[tuple[str, Any]] = [
                (f"viz/{name}", fm.PoseInFrame(timestamp=stamp, frame_id=FRAME, pose=pose3(msg.x, msg.y, msg.theta)))
            ]
            if suffix == "pose":
                self.pose = msg
                tf = fm.FrameTransform(
                    timestamp=stamp,
                    parent_frame_id=FRAME,
                    child_frame_id=ROBOT_FRAME,
                    translation=fm.Vector3(x=msg.x, y=msg.y, z=0.0),
                    rotation=yaw(msg.theta),
                )
                out.append(("viz/tf", fm.FrameTransforms(transforms=[tf])))
            return out
        if suffix == "field":
            self.field = msg
        elif suffix == "nav/plan":
            self.plan = msg
        elif suffix == "vps/pose":
            self.fixes.append([msg.t, msg.x, msg.y, None])
        elif suffix == "localizer/fixes":
            for fix in self.fixes:
                if abs(fix[0] - msg.t) < 1e-6:
                    fix[3] = msg.accepted
            if not msg.accepted:
                text = f"VPS fix at t={msg.t:.2f} s rejected: {msg.reason}"
                return [("viz/log", self._log(stamp, fm.LogLevel.Warning, "localizer", text))]
        elif suffix == "nav/state":
            before, self.nav = self.nav, msg
            if before is None or (before.state, before.goal_id, before.result) != (msg.state, msg.goal_id, msg.result):
                text = f"{msg.state} goal {msg.goal_id}" + (f": {msg.result}" if msg.result else "")
                text += f" ({msg.message})" if msg.message else ""
                level = fm.LogLevel.Warning if msg.result == GoalResult.ABORTED else fm.LogLevel.Info
                return [("viz/log", self._log(stamp, level, "navigator", text))]
        elif suffix.startswith("diag/"):
            was = self.status.get(msg.service)
            self.status[msg.service] = msg.status
            if was is not None and was != msg.status:
                level = fm.LogLevel.Info if msg.status == "ok" else fm.LogLevel.Warning
                return [("viz/log", self._log(stamp, level, msg.service, f"status {msg.status}: {msg.message}"))]
        return []

    def _log(self, stamp: fm.Timestamp, level: fm.LogLevel, name: str, text: str) -> fm.Log:
        return fm.Log(timestamp=stamp, level=level, name=f"{self.robot}/{name}", message=text)

    def scene(self, ns: int) -> fm.SceneUpdate:
        """Every drawn entity as it is now."""
        stamp = timestamp(ns)

        def entity(id: str, **primitives: Any) -> fm.SceneEntity:
            return fm.SceneEntity(timestamp=stamp, frame_id=FRAME, id=id, **primitives)

        entities = [entity(f"trail/{name}", lines=[line(trail.points, name)]) for name, trail in self.trails.items()]
        fix_colour = {None: "fix", True: "fix_accepted", False: "fix_rejected"}
        entities.append(
            entity(
                "vps/fixes",
                spheres=[
                    fm.SpherePrimitive(pose=pose3(x, y), size=fm.Vector3(x=0.03, y=0.03, z=0.03), color=colour(fix_colour[ok]))
                    for _, x, y, ok in self.fixes
                ],
            )
        )
        pose, nav = self.pose, self.nav
        ell = ellipse(pose.cov) if pose is not None else None
        entities.append(entity("pose/covariance", cylinders=[disc(pose.x, pose.y, *ell, "ellipse")] if pose is not None and ell else []))
        # The way still to go: from the robot through the goal's points not reached yet.
        points = goal_points(nav.goal) if nav is not None and nav.result is None else []
        ahead = points[nav.next_point or 0 :] if nav is not None and points else []
        if ahead and pose is not None:
            ahead = [(pose.x, pose.y), *ahead]
        entities.append(
            entity(
                "nav/goal",
                lines=[line(ahead, "goal", width=3.0)] if len(ahead) > 1 else [],
                cylinders=[disc(x, y, 0.04, 0.04, 0.0, "goal") for x, y in points[-1:]],
            )
        )
        texts = []
        if self.nav is not None and self.pose is not None:
            left = self.nav.distance_remaining
            texts.append(
                fm.TextPrimitive(
                    pose=pose3(self.pose.x, self.pose.y, z=0.15),
                    billboard=True,
                    font_size=14.0,
                    scale_invariant=True,
                    color=colour("text"),
                    text=self.nav.state + (f"  {left:.2f} to go" if left is not None else ""),
                )
            )
        entities.append(entity("nav/state", texts=texts))
        plan = self.plan if self.plan is not None and nav is not None and nav.result is None and self.plan.goal_id == nav.goal_id else None
        entities.append(entity("nav/plan", lines=[line([tuple(p[:2]) for p in plan.points], "plan", width=2.0, z=0.003)] if plan else []))
        entities.append(entity("field", lines=field_lines(self.field) if self.field is not None else []))
        return fm.SceneUpdate(entities=entities)


def field_lines(f: m.FieldMap) -> list[fm.LinePrimitive]:
    """The field's edge and its obstacles' outlines (a disc as a 32-sided polygon), closed."""
    out = []
    if f.enabled:
        corners = [(f.x_min, f.y_min), (f.x_max, f.y_min), (f.x_max, f.y_max), (f.x_min, f.y_max)]
        out.append(line([*corners, corners[0]], "edge"))
    for o in f.obstacles:
        if "circle" in o:
            x, y, r = o["circle"]
            pts = [(x + r * math.cos(k * math.pi / 16), y + r * math.sin(k * math.pi / 16)) for k in range(33)]
        else:
            pts = [(p[0], p[1]) for p in o.get("polygon", [])]
            pts = [*pts, pts[0]] if pts else []
        out.append(line(pts, "obstacle", width=3.0))
    return out


def line(points: Any, name: str, width: float = 2.0, z: float = 0.002) -> fm.LinePrimitive:
    """A polyline through (x, y) points, `width` pixels wide."""
    return fm.LinePrimitive(
        type=fm.LinePrimitiveLineType.LineStrip,
        pose=pose3(0.0, 0.0),
        thickness=width,
        scale_invariant=True,
        points=[fm.Point3(x=x, y=y, z=z) for x, y in points],
        color=colour(name),
    )


def disc(x: float, y: float, a: float, b: float, angle: float, name: str) -> fm.CylinderPrimitive:
    """A flat ellipse on the ground: semi-axes a, b [m], the first along `angle` [rad]."""
    return fm.CylinderPrimitive(
        pose=pose3(x, y, angle, z=0.001),
        size=fm.Vector3(x=2 * a, y=2 * b, z=0.002),
        bottom_scale=1.0,
        top_scale=1.0,
        color=colour(name),
    )
