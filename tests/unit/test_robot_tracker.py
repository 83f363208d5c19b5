"""Goal ends from nav/state alone (common.navgoals, under the robot library)."""

import pytest

from zenav.common import messages as m
from zenav.common.navgoals import GoalEnd, GoalTracker


def state(t, goal_id, state="MOVING_TO_POINT", result=None, elapsed=0.0, message="", exit=None):
    return m.NavState(t=t, state=state, goal_id=goal_id, result=result, elapsed=elapsed, message=message, exit=exit)


def test_a_goal_ends_with_its_result_and_elapsed_time():
    track = GoalTracker()
    track.on_state(state(10.0, 1, elapsed=0.5))  # started at 9.5
    assert track.end(1) is None and track.current(1) and track.state(1).elapsed == 0.5
    track.on_state(state(12.0, 1, "STOPPED", "succeeded", message="arrived", exit="within_tolerance"))
    assert track.end(1) == GoalEnd("succeeded", "arrived", pytest.approx(2.5), "within_tolerance")


def test_a_newer_goal_preempts():
    track = GoalTracker()
    track.on_state(state(10.0, 1))
    track.on_state(state(11.0, 2, "TURNING_TO_HEADING", elapsed=0.25))
    assert track.end(1) == GoalEnd("cancelled", "preempted by goal 2", pytest.approx(0.75), "cancelled") and not track.current(1)
    assert track.end(2) is None and track.end(3) is None


def test_unseen_starts_give_no_elapsed_old_goals_go_and_forget_restarts_the_count():
    track = GoalTracker(keep=2)
    track.on_state(state(5.0, 4, "STOPPED", "aborted", message="pose stale"))
    assert track.end(4) == GoalEnd("aborted", "pose stale", None)
    track.on_state(state(6.0, 7))
    assert track.state(4) is None and track.state(7) is not None  # too old: 2 ids kept
    track.forget()
    assert track.newest is None and track.state(7) is None and track.end(1) is None
