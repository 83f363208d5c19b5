"""The navigator's request bookkeeping: leases, the running request, the waiters."""

from zenav.common.contract import State
from zenav.services.navigator.goals import Goal
from zenav.services.navigator.requests import LOST, START, Request, Requests

GOAL = Goal(State.MOVING_TO_POINT, points=((1.0, 0.0),), speed=0.2, tolerance=0.01)


def request(wait=False):
    return Request(GOAL, {"type": "move_to_point"}, wait, reply_to=object())


def test_a_pending_request_starts_when_its_lease_is_seen():
    book, r = Requests(), request()
    assert book.hold(r, "zenav/r1/lease/me", deadline=1.5) is None
    assert book.on_lease(r, False) is None  # not running yet: nothing to lose
    assert book.on_lease(r, True) == START and book.pending is None
    assert book.on_lease(r, True) is None  # seen twice: started once


def test_a_newer_request_supersedes_the_pending_one():
    book, old, new = Requests(), request(), request()
    book.hold(old, "a", 1.0)
    assert book.hold(new, "b", 2.0) is old and book.pending is new
    assert book.on_lease(old, True) is None  # its token comes too late


def test_a_lease_not_seen_by_its_deadline_expires():
    book, r = Requests(), request()
    book.hold(r, "a", deadline=1.0)
    assert book.expired(0.99) is None and book.expired(1.0) is r and book.pending is None


def test_a_running_request_loses_its_lease():
    book, r = Requests(), request()
    book.started(r, 7)
    assert book.on_lease(r, False) == LOST and book.on_lease(request(), False) is None


def test_the_end_of_a_goal_releases_its_request_and_its_waiter():
    book, r = Requests(), request(wait=True)
    book.started(r, 3)
    assert book.ended(2) == (None, None)
    assert book.ended(3) == (r, r) and book.running is None and book.waiters == {}


def test_a_preempted_waiter_is_answered_after_the_new_goal_runs():
    book, first, second = Requests(), request(wait=True), request()
    book.started(first, 1)
    book.started(second, 2)  # preempts 1: its waiter stays until its end is reported
    assert book.ended(1) == (None, first) and book.running is second
