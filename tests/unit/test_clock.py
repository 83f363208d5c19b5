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


def test_a_jump_back_from_the_same_owner_is_refused():
    c = ticked(50.0, 50.01)
    assert c.update(Clock(t=45.0)) == ck.REFUSED and "back" in c.refusal and c.now() >= 50.01


def test_a_new_owner_is_a_restart():
    c = SimClock()
    c.sim_token("sim-a", True)
    assert c.update(Clock(t=50.0, instance="sim-a")) == ck.ACCEPTED
    c.sim_token("sim-a", False)  # the sim died; a new one came
    c.sim_token("sim-b", True)
    assert c.update(Clock(t=0.01, instance="sim-b")) == ck.RESTARTED and c.now() < 0.07 and c.owner == "sim-b"


def test_a_tick_from_another_instance_while_the_owner_lives_is_foreign():
    c = SimClock()
    c.sim_token("sim-a", True)
    assert c.update(Clock(t=50.0, instance="sim-a")) == ck.ACCEPTED
    for stray in ("", "sim-old", "sim-b"):  # a replay, a client, a second sim that slipped in
        c.sim_token("sim-b", stray == "sim-b")
        assert c.update(Clock(t=45.0, instance=stray)) == ck.FOREIGN and c.owner == "sim-a" and c.now() >= 50.0
    assert c.foreign == 3 and "sim-a" in c.refusal
    assert c.update(Clock(t=50.01, instance="sim-a")) == ck.ACCEPTED


def test_a_stray_before_the_first_tick_is_foreign_while_a_sim_lives():
    c = SimClock()
    c.sim_token("sim-a", True)
    assert c.update(Clock(t=45.0, instance="replayed")) == ck.FOREIGN and not c.ready
    assert c.update(Clock(t=50.0, instance="sim-a")) == ck.ACCEPTED and c.owner == "sim-a"


def test_without_any_sim_token_the_first_sender_owns_the_clock():
    c = ticked(5.0, 5.01)  # a replay into a stack without a sim: no token
    assert c.owner == "" and c.update(Clock(t=5.02)) == ck.ACCEPTED


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
