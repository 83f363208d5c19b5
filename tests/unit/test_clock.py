"""The sim clock: plausible ticks only, restarts, and the future-stamp horizon."""

import time

import pytest

from zenav.common import clock as ck
from zenav.common.clock import SimClock, WallClock
from zenav.common.messages import Clock


def ticked(*ts, rtf=1.0, **kw):
    c = SimClock(**kw)
    for t in ts:
        assert c.update(Clock(t=t, rtf=rtf)) == ck.ACCEPTED
    return c


def test_an_absurd_rtf_is_refused_and_time_stays():
    c = ticked(5.0, 5.01)
    assert c.update(Clock(t=5.02, rtf=200.0)) == ck.REFUSED
    assert c.refused == 1 and "rtf 200" in c.refusal and c.now() < 5.07


def test_an_rtf_change_without_a_restart_is_refused():
    c = ticked(5.0)
    assert c.update(Clock(t=5.01, rtf=50.0)) == ck.REFUSED and "changed" in c.refusal


def test_a_jump_ahead_faster_than_the_rtf_allows_is_refused():
    c = ticked(5.0, jump=1.0)
    assert c.update(Clock(t=15.0)) == ck.REFUSED and "jumped" in c.refusal
    assert c.update(Clock(t=5.5)) == ck.ACCEPTED  # within the jump


def test_a_jump_back_is_a_restart():
    c = ticked(50.0, 50.01)
    assert c.update(Clock(t=0.01)) == ck.RESTARTED and c.now() < 0.07


def test_agreeing_refused_ticks_become_the_new_timeline():
    c = ticked(5.0)
    outcomes = [c.update(Clock(t=900.0 + 0.01 * i)) for i in range(ck.REFUSED_RUN)]
    assert outcomes == [ck.REFUSED] * (ck.REFUSED_RUN - 1) + [ck.RESTARTED] and c.now() >= 900.0


def test_a_glitch_between_good_ticks_does_not_start_a_run():
    c = ticked(5.0)
    for i in range(ck.REFUSED_RUN * 2):
        c.update(Clock(t=5.0 + 0.01 * i))
        assert c.update(Clock(t=900.0)) == ck.REFUSED
    assert c.now() < 6.0


@pytest.mark.parametrize("rtf", [1.0, 10.0])
def test_the_horizon_allows_one_tick_and_the_slack_only(rtf):
    c = ticked(10.0, 10.01, rtf=rtf, max_extrapolation=0.0, future=0.1)
    assert c.horizon() == pytest.approx(10.01 + 0.01 + 0.1)
    assert 10.02 < c.horizon() < 10.01 + 0.9


def test_the_wall_clock_admits_up_to_the_slack_ahead():
    c = WallClock(future=0.1)
    assert c.admits(c.now() + 0.05) and not c.admits(c.now() + 0.5)


def test_at_a_high_rtf_the_interpolation_stays_within_a_tick():
    c = SimClock(future=0.1)
    for t in (10.0, 10.01):
        c.update(Clock(t=t, rtf=100.0, wall=time.time() - 1.0))  # a tick taken late: a second of wall time is 100 s of sim
    assert c.now() == pytest.approx(10.02)
    assert c.horizon() == pytest.approx(10.13) and c.horizon() < 10.01 + 0.9


@pytest.mark.parametrize("extrapolation", [0.0, 0.25])
def test_admits_agrees_with_the_horizon(extrapolation):
    c = SimClock(max_extrapolation=extrapolation, future=0.1)
    assert c.admits(1e9)  # before the first tick nothing is from the future
    for t in (10.0, 10.01):
        c.update(Clock(t=t, wall=time.time() - 1.0))  # taken late: now() runs a whole tick past the newest (if it may)
    c.now()
    edge = c.horizon()
    for t in (10.0, 10.11, edge - 1e-6):
        assert c.admits(t)
    for t in (edge + 1e-3, 10.5, 1e9):
        assert not c.admits(t)
