"""The goal state machine: transitions, results, checks and path switching."""

import math

import pytest

from zenav.common.config import Field
from zenav.common.contract import GoalResult, State
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
    return Goal(State.MOVING_TO_POINT, points=((x, y),), speed=0.2, tolerance=tol)


def test_idle_machine_commands_nothing():
    mc = GoalMachine(Params(), WHEELS)
    assert mc.state == State.STOPPED and not mc.active
    assert mc.on_pose(PoseSample(0.0, 0.0, 0.0, 0.0)) == (None, None)
    assert mc.check(10.0) is None and mc.cancel("stopped") is None
    assert mc.feedback(0.0) == goals.Feedback()


def test_refused_without_a_pose_or_with_a_stale_one():
    with pytest.raises(Refused, match="no pose"):
        GoalMachine(Params(), WHEELS).start(to_point(1.0, 0.0), 0.0)
    with pytest.raises(Refused, match="stale"):
        machine().start(to_point(1.0, 0.0), 0.6)


def test_arrival_rests_at_zero_then_succeeds():
    mc = machine(rest_time=0.2)
    assert mc.start(to_point(0.005, 0.0), 0.0) is None  # already within tolerance: the move ends at once
    assert mc.state == State.MOVING_TO_POINT and mc.goal_id == 1 and mc.result is None
    cmd, end = mc.on_pose(PoseSample(0.01, 0.0101, 0.0, 0.0))  # zero is held
    assert cmd == (0.0, 0.0) and end is None and mc.active
    cmd, end = mc.on_pose(PoseSample(0.22, 0.0101, 0.0, 0.0))
    assert cmd == (0.0, 0.0) and end == goals.End(1, GoalResult.SUCCEEDED, "arrived", stop=True, exit="within_tolerance")
    assert mc.state == State.STOPPED and mc.result == GoalResult.SUCCEEDED and mc.exit == "within_tolerance" and not mc.active


def test_a_stop_while_the_wheels_slip_is_judged_once_the_fixes_say_where_the_robot_is():
    mc = machine(rest_time=0.2, slip_wait=1.5, retries=0)
    mc.start(to_point(0.005, 0.0), 0.0)  # within tolerance at once: the move stops on the next pose
    assert mc.on_pose(PoseSample(0.01, 0.005, 0.0, 0.0, slipping=True)) == ((0.0, 0.0), None)
    # Past rest_time the localizer still finds the wheels slipping (a wall holds the robot): no verdict yet.
    assert mc.on_pose(PoseSample(0.5, 0.005, 0.0, 0.0, slipping=True)) == ((0.0, 0.0), None) and mc.active
    # The fixes put the robot 6 cm short, and the slip is over: the verdict, saying why.
    cmd, end = mc.on_pose(PoseSample(1.0, -0.055, 0.0, 0.0))
    assert cmd == (0.0, 0.0) and end is not None and end.result == GoalResult.ABORTED
    why = "(the wheels slipped: held by a wall or a robot?)"
    assert end.message == f"stopped 6.00 cm from the goal (tolerance 1.00 cm): exit within_tolerance {why}"


def test_a_move_held_where_it_stopped_is_not_retried_one_that_stopped_free_is():
    held = GoalMachine(Params(rest_time=0.2, slip_wait=1.5), WHEELS)  # retries: 2
    held.on_pose(PoseSample(0.0, 0.0, 0.0, 0.0, slipping=True))  # pushing against a wall
    held.start(to_point(0.005, 0.0), 0.0)  # stops at once, still slipping
    cmd, end = held.on_pose(PoseSample(1.0, -0.055, 0.0, 0.0))
    assert end is not None and end.result == GoalResult.ABORTED and end.message.endswith("held by a wall or a robot?)")

    free = machine(rest_time=0.2, slip_wait=1.5)
    free.start(to_point(0.005, 0.0), 0.0)  # stops at once, the wheels gripping
    free.on_pose(PoseSample(0.1, 0.005, 0.0, 0.0, slipping=True))  # bumped while at rest
    cmd, end = free.on_pose(PoseSample(1.0, -0.055, 0.0, 0.0))
    assert end is None and cmd[0] > 0.0 and free.active  # moves again


def test_a_slip_that_lasts_is_waited_for_slip_wait_at_most():
    mc = machine(rest_time=0.2, slip_wait=1.5)
    mc.start(to_point(0.005, 0.0), 0.0)
    mc.on_pose(PoseSample(0.01, 0.005, 0.0, 0.0, slipping=True))
    assert mc.on_pose(PoseSample(1.69, 0.005, 0.0, 0.0, slipping=True)) == ((0.0, 0.0), None)  # stopped at 0
    cmd, end = mc.on_pose(PoseSample(1.71, 0.005, 0.0, 0.0, slipping=True))
    assert end == goals.End(1, GoalResult.SUCCEEDED, "arrived", stop=True, exit="within_tolerance")


def test_a_point_outside_tolerance_is_driven_to():
    mc = machine()
    mc.start(to_point(0.02, 0.0), 0.0)
    cmd, end = mc.on_pose(PoseSample(0.01, 0.0, 0.0, 0.0))
    assert cmd[0] > 0 and end is None


def test_preemption_is_a_handover():
    mc = machine()
    mc.start(to_point(1.0, 0.0), 0.0)
    end = mc.start(to_point(0.0, 1.0), 0.1)
    assert end == goals.End(1, GoalResult.CANCELLED, "preempted by goal 2", stop=False, exit="cancelled")
    assert mc.goal_id == 2 and mc.state == State.MOVING_TO_POINT and mc.result is None


@pytest.mark.parametrize("how, result", [("cancel", GoalResult.CANCELLED), ("abort", GoalResult.ABORTED)])
def test_cancel_and_abort_stop(how, result):
    mc = machine()
    mc.start(to_point(1.0, 0.0), 0.0)
    end = getattr(mc, how)("why")
    assert end == goals.End(1, result, "why", stop=True, exit=result) and mc.message == "why"
    assert mc.on_pose(PoseSample(0.1, 0.0, 0.0, 0.0)) == (None, None)


def test_a_pose_steered_on_through_odometry_ages_from_its_localizer_pose():
    mc = machine()
    mc.start(to_point(1.0, 0.0), 0.0)
    for k in range(1, 61):  # odom samples every 10 ms, all corrected by the pose of t = 0
        mc.on_pose(PoseSample(k * 0.01, k * 0.001, 0.0, 0.0, pose_t=0.0))
    assert mc.pose.t == pytest.approx(0.6) and mc.pose.since == 0.0
    end = mc.check(0.6)
    assert end is not None and end.result == GoalResult.ABORTED and "stale" in end.message


def test_a_pose_heard_between_odom_samples_counts_at_once():
    mc = machine()
    mc.on_pose(PoseSample(0.02, 0.2, 0.0, 0.0, pose_t=0.0))
    mc.heard(PoseSample(0.01, 0.1, 0.0, 0.0, 0.0, 0.0, 0.3, 0.4))  # older than the sample steered on: its age and sigmas
    assert (mc.pose.t, mc.pose.x, mc.pose.since, mc.pose.sigma_xy, mc.pose.sigma_theta) == (0.02, 0.2, 0.01, 0.3, 0.4)
    mc.heard(PoseSample(0.03, 0.3, 0.0, 0.0))  # newer: the newest pose
    assert (mc.pose.t, mc.pose.x, mc.pose.since) == (0.03, 0.3, 0.03)


def test_stale_pose_aborts():
    mc = machine()
    mc.start(to_point(1.0, 0.0), 0.0)
    assert mc.check(0.5) is None
    end = mc.check(0.51)
    assert end.result == GoalResult.ABORTED and "stale" in end.message


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
    assert end.result == GoalResult.ABORTED and "position sigma 0.600 m" in end.message


def test_pose_sigma_is_the_worst_axis_of_the_covariance():
    assert sigmas((4.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.09)) == pytest.approx((2.0, 0.3))
    sxy, _ = sigmas((1.0, 1.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0))  # fully correlated: 2 along the diagonal
    assert sxy == pytest.approx(math.sqrt(2.0))


@pytest.mark.parametrize("slipping", [False, True])
def test_no_progress_aborts_after_the_timeout(slipping):
    mc = machine(progress_timeout=2.0)
    mc.start(to_point(1.0, 0.0), 0.0)
    t, end = 0.0, None
    while end is None and t < 10.0:
        t = round(t + 0.05, 2)
        mc.on_pose(PoseSample(t, 0.0, 0.0, 0.0, slipping=slipping and t < 0.5))  # stuck (against a robot: slipping)
        end = mc.check(t)
    assert end.result == GoalResult.ABORTED and end.message.startswith("no progress for 2.") and t == pytest.approx(2.05)
    assert end.message.endswith("(the wheels slipped: held by a wall or a robot?)") == slipping


def test_slow_progress_is_progress():
    mc = machine(progress_timeout=2.0)
    mc.start(to_point(1.0, 0.0), 0.0)
    for i in range(1, 200):
        t = i * 0.05
        mc.on_pose(PoseSample(t, 0.006 * t, 0.0, 0.0))  # 6 mm/s
        assert mc.check(t) is None


def test_path_switches_points_in_order_and_invalidates_the_old_distance():
    mc = machine()
    path = Goal(State.FOLLOWING_PATH, points=((1.0, 0.0), (1.0, 1.0), (0.0, 1.0)), speed=0.2, tolerance=0.01)
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
    mc.start(Goal(State.TURNING_TO_HEADING, heading=-1.0, speed=2.0, tolerance=0.0175), 0.0)
    cmd, _ = mc.on_pose(PoseSample(0.01, 0.0, 0.0, 0.0))
    assert cmd[0] == 0.0 and cmd[1] < 0
    fb = mc.feedback(0.01)
    assert fb.heading_error == pytest.approx(-1.0) and fb.distance_remaining == pytest.approx(1.0) and fb.eta == pytest.approx(0.5)
    mc = machine()
    mc.start(Goal(State.TURNING_TO_HEADING, heading=1.0, speed=2.0, tolerance=0.0175), 0.0)
    cmd, _ = mc.on_pose(PoseSample(0.02, 0.0, 0.0, 0.999))
    assert cmd == (0.0, 0.0)  # the coast takes it there


def test_straight_with_a_distance_stops_there_and_without_runs_on():
    mc = machine()
    mc.start(Goal(State.MOVING_STRAIGHT, speed=-0.1, distance=0.5, tolerance=0.01), 0.0)
    cmd, _ = mc.on_pose(PoseSample(0.01, -0.2, 0.0, 0.0))
    assert cmd[0] == pytest.approx(-0.1) and mc.feedback(0.01).distance_remaining == pytest.approx(0.3)
    cmd, _ = mc.on_pose(PoseSample(0.02, -0.5, 0.0, 0.0))
    assert cmd == (0.0, 0.0)
    mc.start(Goal(State.MOVING_STRAIGHT, speed=0.1, tolerance=0.01), 0.02)
    cmd, _ = mc.on_pose(PoseSample(0.03, 100.0, 0.0, 0.0))
    assert cmd[0] == pytest.approx(0.1) and mc.feedback(0.03).distance_remaining is None


def test_straight_steers_back_to_the_line():
    mc = machine()
    mc.start(Goal(State.MOVING_STRAIGHT, speed=0.1, tolerance=0.01), 0.0)
    assert mc.on_pose(PoseSample(0.01, 0.1, 0.02, 0.0))[0][1] < 0  # left of the line: turn right
    mc = machine()
    mc.start(Goal(State.MOVING_STRAIGHT, speed=-0.1, tolerance=0.01), 0.0)
    assert mc.on_pose(PoseSample(0.01, -0.1, 0.02, 0.0))[0][1] > 0  # reversing: the other way


def test_path_rest_is_the_length_after_each_point():
    assert goals.path_rest(((0.0, 0.0), (3.0, 4.0), (3.0, 5.0))) == [6.0, 1.0, 0.0]
    assert goals.path_rest(((2.0, 2.0),)) == [0.0]
    many = tuple((0.001 * i, 0.0) for i in range(10_001))
    rest = goals.path_rest(many)
    assert len(rest) == 10_001 and rest[0] == pytest.approx(10.0) and rest[5000] == pytest.approx(5.0)


def test_bunched_points_are_passed_a_bounded_number_per_pose():
    mc = machine()
    n = 3 * goals.MAX_SWITCHES
    mc.start(Goal(State.FOLLOWING_PATH, points=((0.001, 0.0),) * n + ((1.0, 0.0),), speed=0.2, tolerance=0.01), 0.0)
    assert mc.feedback(0.0).next_point == goals.MAX_SWITCHES
    mc.on_pose(PoseSample(0.01, 0.0, 0.0, 0.0))
    assert mc.feedback(0.01).next_point == 2 * goals.MAX_SWITCHES


FIELD = Field(x_min=-1.0, x_max=3.0, y_min=-1.0, y_max=3.0)


@pytest.mark.parametrize(
    "goal, words",
    [
        (to_point(3.5, 0.0), "x, y: 3.5 m is outside the field ([field] x_max = 3.0)"),
        (Goal(State.FOLLOWING_PATH, points=((0.0, 1.0), (0.0, -2.0)), speed=0.2), "points[1]: -2 m"),
        (Goal(State.MOVING_STRAIGHT, speed=-0.1, distance=1.5), "distance: the end is outside"),
    ],
)
def test_targets_outside_the_field_name_the_bound(goal, words):
    assert words in goals.outside(goal, PoseSample(0.0, 0.0, 0.0, 0.0), FIELD)


def test_targets_inside_the_field_or_without_an_end_pass():
    pose = PoseSample(0.0, 0.0, 0.0, 0.0)
    for goal in (to_point(3.0, -1.0), Goal(State.MOVING_STRAIGHT, speed=0.1), Goal(State.TURNING_TO_HEADING, heading=1.0)):
        assert goals.outside(goal, pose, FIELD) is None
    assert goals.outside(to_point(30.0, 0.0), pose, Field(enabled=False)) is None


def test_a_pose_outside_the_field_aborts_the_goal():
    mc = GoalMachine(Params(), WHEELS, FIELD)
    mc.on_pose(PoseSample(0.0, 2.9, 0.0, 0.0))
    mc.start(Goal(State.MOVING_STRAIGHT, speed=0.2), 0.0)
    cmd, end = mc.on_pose(PoseSample(0.01, 3.01, 0.0, 0.0))
    assert cmd == (0.0, 0.0) and end.result == GoalResult.ABORTED and end.stop and end.message.startswith("left the field")


def test_a_goal_started_outside_the_field_may_bring_the_robot_back_not_farther_out():
    half_pi = math.pi / 2
    mc = GoalMachine(Params(), WHEELS, FIELD)
    mc.on_pose(PoseSample(0.0, 0.5, -1.011, half_pi))  # stopped 11 mm past y_min
    mc.start(to_point(0.5, 0.0), 0.0)
    for t, y in ((0.1, -1.02), (0.2, -1.025), (0.3, -1.0)):  # a turn's wobble, 1.4 cm farther out at most, then back in
        cmd, end = mc.on_pose(PoseSample(t, 0.5, y, half_pi))
        assert end is None and cmd is not None, (y, end)
    cmd, end = mc.on_pose(PoseSample(0.4, 0.5, -1.001, half_pi))  # back in, the field's bounds hold again
    assert cmd == (0.0, 0.0) and end.result == GoalResult.ABORTED and end.message.startswith("left the field")
    mc.on_pose(PoseSample(0.5, 0.5, -1.011, -half_pi))
    mc.start(Goal(State.MOVING_STRAIGHT, speed=0.2), 0.5)  # outward
    assert mc.on_pose(PoseSample(0.6, 0.5, -1.030, -half_pi))[1] is None
    end = mc.on_pose(PoseSample(0.7, 0.5, -1.032, -half_pi))[1]
    assert end.result == GoalResult.ABORTED and "farther out than the goal's start allows (0.031 m)" in end.message


def test_move_straight_without_a_distance_has_a_time_limit():
    mc = machine(straight_max_time=1.0)
    mc.start(Goal(State.MOVING_STRAIGHT, speed=0.2), 0.0)
    mc.on_pose(PoseSample(0.9, 0.18, 0.0, 0.0))
    assert mc.check(0.95) is None
    end = mc.check(1.0)
    assert end.result == GoalResult.ABORTED and "straight_max_time" in end.message
