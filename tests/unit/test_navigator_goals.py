"""The goal state machine: transitions, results, checks and path switching."""
import math

import pytest

from zenav.services.navigator import goals
from zenav.services.navigator.controllers import PoseSample, Wheelbase, sigmas
from zenav.services.navigator.goals import Goal, GoalMachine, Refused
from zenav.services.navigator.params import Params

WHEELS = Wheelbase(0.1156, 0.03365, 10.0)


def machine(**cfg):
    mc = GoalMachine(Params(**cfg), WHEELS)
    mc.on_pose(PoseSample(0.0, 0.0, 0.0, 0.0))
    return mc


def to_point(x, y, tol=0.01):
    return Goal(goals.MOVING_TO_POINT, points=((x, y),), speed=0.2, tolerance=tol)


def test_idle_machine_commands_nothing():
    mc = GoalMachine(Params(), WHEELS)
    assert mc.state == goals.STOPPED and not mc.active
    assert mc.on_pose(PoseSample(0.0, 0.0, 0.0, 0.0)) == (None, None)
    assert mc.check(10.0) is None and mc.cancel("stopped") is None
    assert mc.feedback(0.0) == goals.Feedback()


def test_refused_without_a_pose_or_with_a_stale_one():
    with pytest.raises(Refused, match="no pose"):
        GoalMachine(Params(), WHEELS).start(to_point(1.0, 0.0), 0.0)
    with pytest.raises(Refused, match="stale"):
        machine().start(to_point(1.0, 0.0), 0.6)


def test_arrival_settles_at_zero_then_succeeds():
    mc = machine(settle_time=0.2)
    assert mc.start(to_point(0.005, 0.0), 0.0) is None  # already within tolerance, ahead
    assert mc.state == goals.MOVING_TO_POINT and mc.goal_id == 1 and mc.result is None
    cmd, end = mc.on_pose(PoseSample(0.01, 0.0101, 0.0, 0.0))  # now past it: arrived
    assert cmd == (0.0, 0.0) and end is None and mc.active
    cmd, end = mc.on_pose(PoseSample(0.22, 0.0101, 0.0, 0.0))
    assert cmd == (0.0, 0.0) and end == goals.End(1, goals.SUCCEEDED, "arrived", stop=True)
    assert mc.state == goals.STOPPED and mc.result == goals.SUCCEEDED and not mc.active


def test_a_point_inside_tolerance_but_ahead_is_driven_to():
    mc = machine()
    mc.start(to_point(0.008, 0.0), 0.0)
    cmd, end = mc.on_pose(PoseSample(0.01, 0.0, 0.0, 0.0))
    assert cmd[0] > 0 and end is None


def test_preemption_is_a_handover():
    mc = machine()
    mc.start(to_point(1.0, 0.0), 0.0)
    end = mc.start(to_point(0.0, 1.0), 0.1)
    assert end == goals.End(1, goals.CANCELLED, "preempted by goal 2", stop=False)
    assert mc.goal_id == 2 and mc.state == goals.MOVING_TO_POINT and mc.result is None


@pytest.mark.parametrize("how, result", [("cancel", goals.CANCELLED), ("abort", goals.ABORTED)])
def test_cancel_and_abort_stop(how, result):
    mc = machine()
    mc.start(to_point(1.0, 0.0), 0.0)
    end = getattr(mc, how)("why")
    assert end == goals.End(1, result, "why", stop=True) and mc.message == "why"
    assert mc.on_pose(PoseSample(0.1, 0.0, 0.0, 0.0)) == (None, None)


def test_stale_pose_aborts():
    mc = machine()
    mc.start(to_point(1.0, 0.0), 0.0)
    assert mc.check(0.5) is None
    end = mc.check(0.51)
    assert end.result == goals.ABORTED and "stale" in end.message


def test_an_uncertain_pose_refuses_a_goal_and_aborts_a_running_one():
    mc = GoalMachine(Params(max_position_sigma=0.5, max_heading_sigma=0.35), WHEELS)
    mc.on_pose(PoseSample(0.0, 0.0, 0.0, 0.0, sigma_xy=10.0, sigma_theta=math.pi))  # no fix yet
    with pytest.raises(Refused, match="position sigma 10.000 m > 0.500 m"):
        mc.start(to_point(1.0, 0.0), 0.0)
    mc.on_pose(PoseSample(0.01, 0.0, 0.0, 0.0, sigma_xy=0.02, sigma_theta=0.5))
    with pytest.raises(Refused, match="heading sigma"):
        mc.start(to_point(1.0, 0.0), 0.01)
    mc.on_pose(PoseSample(0.02, 0.0, 0.0, 0.0, sigma_xy=0.02, sigma_theta=0.01))
    mc.start(to_point(1.0, 0.0), 0.02)
    assert mc.check(0.03) is None
    mc.on_pose(PoseSample(0.04, 0.01, 0.0, 0.0, sigma_xy=0.6, sigma_theta=0.01))  # the fixes stopped long ago
    end = mc.check(0.05)
    assert end.result == goals.ABORTED and "position sigma 0.600 m" in end.message


def test_pose_sigma_is_the_worst_axis_of_the_covariance():
    assert sigmas((4.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.09)) == pytest.approx((2.0, 0.3))
    sxy, _ = sigmas((1.0, 1.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0))  # fully correlated: 2 along the diagonal
    assert sxy == pytest.approx(math.sqrt(2.0))


def test_no_progress_aborts_after_the_timeout():
    mc = machine(progress_timeout=2.0)
    mc.start(to_point(1.0, 0.0), 0.0)
    t, end = 0.0, None
    while end is None and t < 10.0:
        t = round(t + 0.05, 2)
        mc.on_pose(PoseSample(t, 0.0, 0.0, 0.0))  # stuck
        end = mc.check(t)
    assert end.result == goals.ABORTED and "no progress" in end.message and t == pytest.approx(2.05)


def test_slow_progress_is_progress():
    mc = machine(progress_timeout=2.0)
    mc.start(to_point(1.0, 0.0), 0.0)
    for i in range(1, 200):
        t = i * 0.05
        mc.on_pose(PoseSample(t, 0.006 * t, 0.0, 0.0))  # 6 mm/s
        assert mc.check(t) is None


def test_path_switches_points_in_order_and_invalidates_the_old_distance():
    mc = machine()
    path = Goal(goals.FOLLOWING_PATH, points=((1.0, 0.0), (1.0, 1.0), (0.0, 1.0)), speed=0.2, tolerance=0.01)
    mc.start(path, 0.0)
    fb = mc.feedback(0.0)
    assert fb.next_point == 0 and fb.distance_remaining == pytest.approx(3.0) and fb.eta == pytest.approx(15.0)
    mc.check(0.0)
    mc.on_pose(PoseSample(0.05, 0.995, 0.0, 0.0))  # at the first point
    fb = mc.feedback(0.05)
    assert fb.next_point == 1 and fb.distance_remaining == pytest.approx(2.0, abs=0.01) and fb.elapsed == 0.05
    assert mc._run.best is None  # progress toward the old point no longer counts
    cmd, end = mc.on_pose(PoseSample(0.06, 1.0, 0.995, math.pi / 2))  # the second, passed in one step
    assert mc.feedback(0.06).next_point == 2 and cmd != (0.0, 0.0) and end is None


def test_feedback_errors_of_a_point_goal():
    mc = machine()
    mc.start(to_point(1.0, 0.0), 0.0)
    mc.on_pose(PoseSample(0.1, 0.5, 0.02, 0.1))
    fb = mc.feedback(0.1)
    assert fb.cross_track_error == pytest.approx(0.02)
    assert fb.heading_error == pytest.approx(math.atan2(-0.02, 0.5) - 0.1)
    assert fb.distance_remaining == pytest.approx(math.hypot(0.5, 0.02))


def test_turn_reaches_the_heading():
    mc = machine()
    mc.start(Goal(goals.TURNING_TO_HEADING, heading=-1.0, speed=2.0, tolerance=0.0175), 0.0)
    cmd, _ = mc.on_pose(PoseSample(0.01, 0.0, 0.0, 0.0))
    assert cmd[0] == 0.0 and cmd[1] < 0
    fb = mc.feedback(0.01)
    assert fb.heading_error == pytest.approx(-1.0) and fb.distance_remaining == pytest.approx(1.0) and fb.eta == pytest.approx(0.5)
    mc = machine()
    mc.start(Goal(goals.TURNING_TO_HEADING, heading=1.0, speed=2.0, tolerance=0.0175), 0.0)
    cmd, _ = mc.on_pose(PoseSample(0.02, 0.0, 0.0, 0.999))
    assert cmd == (0.0, 0.0)  # the coast takes it there


def test_straight_with_a_distance_stops_there_and_without_runs_on():
    mc = machine()
    mc.start(Goal(goals.MOVING_STRAIGHT, speed=-0.1, distance=0.5, tolerance=0.01), 0.0)
    cmd, _ = mc.on_pose(PoseSample(0.01, -0.2, 0.0, 0.0))
    assert cmd[0] == pytest.approx(-0.1) and mc.feedback(0.01).distance_remaining == pytest.approx(0.3)
    cmd, _ = mc.on_pose(PoseSample(0.02, -0.5, 0.0, 0.0))
    assert cmd == (0.0, 0.0)
    mc.start(Goal(goals.MOVING_STRAIGHT, speed=0.1, tolerance=0.01), 0.02)
    cmd, _ = mc.on_pose(PoseSample(0.03, 100.0, 0.0, 0.0))
    assert cmd[0] == pytest.approx(0.1) and mc.feedback(0.03).distance_remaining is None


def test_straight_steers_back_to_the_line():
    mc = machine()
    mc.start(Goal(goals.MOVING_STRAIGHT, speed=0.1, tolerance=0.01), 0.0)
    assert mc.on_pose(PoseSample(0.01, 0.1, 0.02, 0.0))[0][1] < 0  # left of the line: turn right
    mc = machine()
    mc.start(Goal(goals.MOVING_STRAIGHT, speed=-0.1, tolerance=0.01), 0.0)
    assert mc.on_pose(PoseSample(0.01, -0.1, 0.02, 0.0))[0][1] > 0  # reversing: the other way
