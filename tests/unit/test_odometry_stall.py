"""A wheel commanded to turn whose encoder shows nothing is reported silent, and its travel unmeasured."""

import pytest

from zenav.services.odometry import stall

P = stall.params(ticks_per_rev=360, radius=0.03365, stall_speed=2.0, min_ticks=5.0, min_time=0.3)
DT = 0.01


def run(w, steps, ticks, cmd):
    out = []
    for k in range(steps):
        w, unmeasured, silent = stall.step(w, P, (k + 1) * DT, DT, ticks, cmd)
        out.append((unmeasured, silent))
    return w, out


def test_a_commanded_wheel_without_ticks_turns_silent_after_the_time_and_ticks():
    w, out = run(stall.Watch(), 40, (0, 3), (5.0, 5.0))  # left frozen, right counting
    first = next(k for k, (_, silent) in enumerate(out) if silent[0])
    assert first + 1 == 30  # 0.3 s (5 rad/s owes 5 ticks after 0.017 s already)
    unmeasured, silent = out[-1]
    assert silent == (True, False) and unmeasured[0] == pytest.approx(5.0 * DT * 0.03365) and unmeasured[1] == 0.0


def test_a_tick_or_a_command_under_the_deadband_clears_it():
    w, out = run(stall.Watch(), 40, (0, 3), (5.0, 5.0))
    w, out = run(w, 1, (1, 3), (5.0, 5.0))
    assert out[-1] == ((0.0, 0.0), (False, False))
    w, out = run(w, 100, (0, 0), (1.0, 1.0))  # a crawl the deadband may swallow
    assert not any(silent[0] or silent[1] for _, silent in out)


def test_a_sample_that_says_nothing_was_commanded_is_never_silent():
    w, out = run(stall.Watch(), 100, (0, 0), (0.0, 0.0))  # a source that does not know its commands sends 0
    assert not any(silent[0] or silent[1] for _, silent in out)


def test_a_coarse_encoder_gets_the_time_its_ticks_need():
    coarse = stall.params(ticks_per_rev=16, radius=0.03365, stall_speed=2.0, min_ticks=5.0, min_time=0.3)
    w, silent_at = stall.Watch(), None
    for k in range(200):
        w, _, silent = stall.step(w, coarse, (k + 1) * DT, DT, (0, 0), (2.0, 2.0))
        if silent[0] and silent_at is None:
            silent_at = (k + 1) * DT
    assert silent_at == pytest.approx(5.0 / (2.0 * 16 / (2 * 3.141592653589793)), abs=0.011)  # 0.98 s
