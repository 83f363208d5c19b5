"""What the live view draws: covariance ellipses, trails, fixes, goals and event logs."""

from __future__ import annotations

import math

import pytest
from foxglove import messages as fm

from zenav.common import messages as m
from zenav.tools import scene as sc

NS = 1_700_000_000_123_456_789


def pose(x=0.0, y=0.0, theta=0.0, cov=m.ZERO_COV, t=1.0):
    return m.Pose(t=t, x=x, y=y, theta=theta, v=0.0, omega=0.0, cov=cov)


def test_ellipse_axes_are_the_sigmas_of_the_xy_block():
    a, b, angle = sc.ellipse((4e-4, 0, 0, 0, 1e-4, 0, 0, 0, 9.0))
    assert (a, b) == pytest.approx((sc.ELLIPSE_SIGMA * 0.02, sc.ELLIPSE_SIGMA * 0.01))
    assert math.sin(angle) == pytest.approx(0.0, abs=1e-9)  # major axis along x
    # rotated by 45 deg: correlated x and y
    a, b, angle = sc.ellipse((2.5e-4, 1.5e-4, 0, 1.5e-4, 2.5e-4, 0, 0, 0, 0))
    assert (a, b) == pytest.approx((sc.ELLIPSE_SIGMA * 0.02, sc.ELLIPSE_SIGMA * 0.01))
    assert math.tan(angle) == pytest.approx(1.0)
    assert sc.ellipse(m.ZERO_COV) is None


def test_goal_points_of_each_goal_kind():
    assert sc.goal_points({"type": "move_to_point", "x": 1, "y": 0.5}) == [(1.0, 0.5)]
    assert sc.goal_points({"type": "follow_path", "points": [[0, 0], [1, 2]]}) == [(0.0, 0.0), (1.0, 2.0)]
    assert sc.goal_points({"type": "move_straight", "speed": 0.2}) == []
    assert sc.goal_points(None) == []


def test_timestamps_split_nanoseconds():
    ts = sc.timestamp(NS)
    assert (ts.sec, ts.nsec) == (1_700_000_000, 123_456_789)


def test_poses_go_out_at_once_and_the_fused_one_moves_base_link():
    s = sc.Scene("r1")
    out = dict(s.update("sim/truth", m.Truth(t=1.0, x=1, y=2, theta=0, v=0, omega=0), NS))
    assert isinstance(out["viz/truth"], fm.PoseInFrame)
    out = dict(s.update("pose", pose(1.0, 2.0, 0.3), NS))
    assert set(out) == {"viz/pose", "viz/tf"} and isinstance(out["viz/tf"], fm.FrameTransforms)
    assert s.update("sensors/imu", m.Imu(t=1.0, gyro_z=0, accel_x=0, accel_y=0), NS) == []


def test_trails_get_a_point_per_centimetre():
    s = sc.Scene("r1")
    for i in range(100):
        s.update("odom", m.Odom(t=i * 0.01, x=i * 0.001, y=0, theta=0, v=0.1, omega=0), NS)
    xs = [x for x, _ in s.trails["odom"].points]
    assert xs[0] == 0.0 and 8 <= len(xs) <= 10  # 0.1 m in 1 mm steps
    assert all(sc.TRAIL_STEP <= b - a < sc.TRAIL_STEP + 0.0011 for a, b in zip(xs, xs[1:]))


def test_fixes_are_marked_accepted_or_rejected_and_rejections_logged():
    s = sc.Scene("r1")
    s.update("vps/pose", m.VpsPose(t=1.0, x=0, y=0, theta=0), NS)
    s.update("vps/pose", m.VpsPose(t=1.1, x=0, y=0, theta=0), NS)

    def fix(t, ok):
        return m.Fix(
            t=t,
            t_arrival=t + 0.3,
            latency=0.3,
            replay_depth=30,
            innovation=(0, 0, 0),
            mahalanobis_d2=20.0,
            accepted=ok,
            reason="" if ok else "gate",
        )

    assert s.update("localizer/fixes", fix(1.0, True), NS) == []
    [(topic, log)] = s.update("localizer/fixes", fix(1.1, False), NS)
    assert topic == "viz/log" and isinstance(log, fm.Log)
    assert [f[3] for f in s.fixes] == [True, False]


def test_navigator_events_are_logged_once_per_change():
    s = sc.Scene("r1")
    moving = m.NavState(t=1.0, state="MOVING_TO_POINT", goal_id=1, goal={"x": 1.0, "y": 0.0})
    assert len(s.update("nav/state", moving, NS)) == 1
    assert s.update("nav/state", moving, NS) == []  # the 5 Hz repeat
    done = m.NavState(t=2.0, state="STOPPED", goal_id=1, result="succeeded")
    assert len(s.update("nav/state", done, NS)) == 1


def test_the_scene_has_every_entity():
    s = sc.Scene("r1")
    s.update("pose", pose(0.5, 0.0, 0.0, cov=(1e-3, 0, 0, 0, 1e-3, 0, 0, 0, 1e-3)), NS)
    s.update("vps/pose", m.VpsPose(t=1.0, x=0.5, y=0.01, theta=0), NS)
    s.update(
        "nav/state",
        m.NavState(t=1.0, state="FOLLOWING_PATH", goal_id=2, goal={"points": [[1, 0], [1, 1]]}, distance_remaining=1.5, next_point=0),
        NS,
    )
    update = s.scene(NS)
    assert isinstance(update, fm.SceneUpdate) and len(update.encode()) > 100
    empty = sc.Scene("r1").scene(NS)  # before any message: the same entities, empty
    assert len(empty.encode()) < len(update.encode())


def test_the_field_and_the_plan_are_drawn():
    s = sc.Scene("r1")
    box = {"name": "box", "polygon": [[0.55, -0.1], [0.75, -0.1], [0.75, 0.1], [0.55, 0.1]]}
    field = m.FieldMap(
        t=1.0,
        enabled=True,
        x_min=-1,
        x_max=3,
        y_min=-1,
        y_max=3,
        obstacles=[box, {"name": "c", "circle": [1, 1, 0.1]}],
        radius=0.1,
        margin=0.05,
    )
    assert len(sc.field_lines(field)) == 3  # the edge, the box, the disc
    size = len(s.scene(NS).encode())
    s.update("field", field, NS)
    with_field = len(s.scene(NS).encode())
    s.update("nav/state", m.NavState(t=1.0, state="MOVING_TO_POINT", goal_id=1, goal={"x": 1.2, "y": 0.0}), NS)
    running = len(s.scene(NS).encode())
    s.update("nav/plan", m.Plan(t=1.0, goal_id=1, points=[(0.5, -0.25), (0.8, -0.25), (1.2, 0.0)], length=1.4, planned=True), NS)
    planned = len(s.scene(NS).encode())
    assert size < with_field and running < planned
    s.update("nav/state", m.NavState(t=2.0, state="STOPPED", goal_id=1, result="succeeded"), NS)
    assert len(s.scene(NS).encode()) < planned  # the plan of a goal that ended is no longer drawn
