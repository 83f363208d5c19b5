"""Cost summaries of a live run: per process, per sweep point, and what ran out."""

from __future__ import annotations

import pytest

from tests.support.bench import live
from zenav.bench import cost
from zenav.services import NAMES


def test_services_cost_per_simulated_second():
    rows = cost.services(live())
    assert [r.name for r in rows] == [*NAMES, "router"]
    sim = rows[0]
    assert sim.cpu_per_sim_s == pytest.approx(0.05) and sim.rss_mb == pytest.approx(40.0)
    assert (sim.msgs_in, sim.msgs_out) == (100.0, 50.0)
    assert rows[-1].cpu_per_sim_s == pytest.approx(0.08)


def test_a_stack_that_keeps_up():
    ld = cost.load(live(robots=2))
    assert ld.keeps_up and ld.why == ""
    assert ld.robots == 2 and ld.cpu_per_robot == pytest.approx(0.3)
    assert ld.stack_cores == pytest.approx((12 * 0.5 + 0.8) / 10.0)
    assert ld.dropped == 12 and ld.msgs_per_s == pytest.approx(12 * 500 / 10.0)
    assert ld.latency.p50 == pytest.approx(3.0)


@pytest.mark.parametrize(
    "kw, why",
    [
        (dict(robots=3, cpu=1.0, speed=0.8), "CPU: the stacks used"),
        (dict(speed=0.9, busy=0.95), "CPU: the machine was 95% busy"),
        (dict(cpu=0.1, hot="localizer", overruns=2), "one process at a full core: localizer of r1"),
        (dict(failures=["r1: aborted: pose stale"]), "not CPU"),
    ],
)
def test_what_ran_out(monkeypatch, kw, why):
    monkeypatch.setattr(cost.os, "cpu_count", lambda: 2)
    ld = cost.load(live(**kw))
    assert not ld.keeps_up
    assert ld.why.startswith(why), ld.why
