"""The fleet section: the router under several robots' traffic, and routers on several hosts."""

from __future__ import annotations

import pytest

from zenav.bench import fleet


def test_the_router_carries_two_robots_traffic(tmp_path):
    points = fleet.router_load((1, 2), 1.0, tmp_path)
    assert [p.robots for p in points] == [1, 2]
    assert all(p.delivered > 0.9 and p.router_cores > 0.0 and p.latency.n > 0 for p in points)
    assert fleet.expected(2, 1.0) == 2 * fleet.expected(1, 1.0)


def test_robots_on_linked_hosts_hear_each_other_and_survive_a_hosts_loss(tmp_path):
    why = fleet.netns_available()
    if why is not None:
        pytest.skip(why)
    res = fleet.hosts(3, phase=2.0, log_dir=tmp_path)
    assert res.heard_all
    assert res.longest_gap < fleet.GAP and not res.lost_heard
