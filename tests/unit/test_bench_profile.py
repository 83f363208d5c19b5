"""The profile section: every service of one robot timed on the in-process bus."""

from __future__ import annotations

import time

from zenav.bench import profile


def test_every_service_is_timed_and_the_chain_runs():
    costs = profile.measure(seconds=1.0, warmup=3.0)
    assert list(costs) == list(profile.ORDER)
    assert all(c.steps == 100 and c.cpu > 0.0 for c in costs.values())
    # the navigator drives: a command per pose, a wheel command per command, an odom per encoder sample
    assert costs["odometry"].outputs >= 100 and costs["navigator"].outputs >= 90 and costs["motor"].outputs >= 90
    assert costs["localizer"].inputs >= 200  # odom and imu at least
    assert 0.0 < costs["odometry"].cores(100.0) < 1.0
    # each input timed by its topic: every encoder sample of the window, and the chain's sample at each service
    assert costs["odometry"].topics["sensors/encoders"][0] == 100
    assert all(costs[s].per_message(t) > 0.0 for s, t in (("localizer", "odom"), ("navigator", "pose"), ("motor", "cmd_vel")))
    assert sum(n for n, _ in costs["localizer"].topics.values()) == costs["localizer"].inputs


def test_the_profile_names_each_services_costliest_functions():
    hot = profile.profile(seconds=3.0, warmup=3.0, top=5)
    assert set(hot) == set(profile.ORDER)
    assert all(len(rows) == 5 and rows[0].own >= rows[-1].own for rows in hot.values())
    assert any("predict" in h.where for h in hot["localizer"])
    costs = profile.measure(seconds=0.2, warmup=3.0)
    text = profile.lines(costs, costs, (1.0, 2.0), hot, 100.0)
    assert any(line.startswith("robot services") for line in text)


def test_paced_steps_are_a_period_apart_and_cost_at_least_some_cpu():
    t0 = time.monotonic()
    paced = profile.measure(seconds=0.3, warmup=3.0, paced=True)
    assert time.monotonic() - t0 >= 0.29  # 30 periods of 10 ms, slept out
    assert all(c.steps == 30 and c.cpu > 0.0 for c in paced.values())
    assert 0.0 < profile.relay(seconds=0.05) and 0.0 < profile.relay(seconds=0.05, paced=True)
