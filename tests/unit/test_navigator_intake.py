"""Goal requests resolved: defaults, clamps and limits."""

import math

import pytest

from zenav.common import messages as m
from zenav.common.contract import State
from zenav.services.navigator import intake
from zenav.services.navigator.controllers import PoseSample
from zenav.services.navigator.params import Params

CFG = Params(max_path_points=3)


def test_defaults_and_clamps():
    goal, info = intake.move_to_point(m.MoveToPoint(x=1.0, y=2.0, speed=9.0), CFG)
    assert goal.points == ((1.0, 2.0),) and goal.speed == CFG.max_speed and goal.tolerance == CFG.tolerance
    assert info == {"type": "move_to_point", "x": 1.0, "y": 2.0, "speed": CFG.max_speed, "tolerance": CFG.tolerance, "forwards": True}
    goal, _ = intake.move_straight(m.MoveStraight(speed=-9.0), CFG)
    assert goal.speed == -CFG.max_speed and goal.distance is None
    goal, info = intake.turn_to_heading(m.TurnToHeading(heading=4.0), CFG)
    assert goal.heading == pytest.approx(4.0 - 2 * math.pi) and goal.speed == CFG.turn_speed and info["heading"] == 4.0


def test_turn_to_point_takes_the_heading_from_the_pose():
    goal, info = intake.turn_to_point(m.TurnToPoint(x=1.0, y=1.0), CFG, PoseSample(0.0, 0.0, 0.0, 0.0))
    assert goal.state == State.TURNING_TO_HEADING and goal.heading == pytest.approx(math.pi / 4) == info["heading"]
    with pytest.raises(intake.Invalid, match="x, y"):
        intake.turn_to_point(m.TurnToPoint(x=0.0, y=0.0), CFG, PoseSample(0.0, 0.0, 0.0, 0.0))


def test_paths_longer_than_the_limit_and_zero_speed_straights_are_invalid():
    goal, info = intake.follow_path(m.FollowPath(points=[(0.0, 1.0), (1.0, 1.0), (1.0, 0.0)]), CFG)
    assert goal.points == ((0.0, 1.0), (1.0, 1.0), (1.0, 0.0)) and len(info["points"]) == 3
    with pytest.raises(intake.Invalid, match="max_path_points = 3"):
        intake.follow_path(m.FollowPath(points=[(0.0, 1.0)] * 4), CFG)
    with pytest.raises(intake.Invalid, match="speed"):
        intake.move_straight(m.MoveStraight(speed=0.0), CFG)


def test_path_tolerances_named_by_points_or_not():
    opts = dict(tolerance=0.02, waypoint_tolerance=0.04)
    plain, _ = intake.follow_path(m.FollowPath(points=[(0.0, 1.0), (1.0, 1.0), (1.0, 0.0)], **opts), CFG)
    assert plain.points == ((0.0, 1.0), (1.0, 1.0), (1.0, 0.0)) and plain.point_tolerances == (0.04, 0.04, 0.02)
    named, _ = intake.follow_path(m.FollowPath(points=[(0.0, 1.0, 0.03), (1.0, 1.0), (1.0, 0.0, 0.05)], **opts), CFG)
    assert named.points == plain.points and named.point_tolerances == (0.03, 0.04, 0.05)
    with pytest.raises(intake.Invalid, match=r"points\[1\]: the tolerance"):
        intake.follow_path(m.FollowPath(points=[(0.0, 1.0), (1.0, 1.0, 0.0), (1.0, 0.0)]), CFG)
