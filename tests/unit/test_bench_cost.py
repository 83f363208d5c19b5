"""Cost summaries of a live run: per process, per sweep point, and what ran out."""
from __future__ import annotations

import pytest

from zenav.common.keys import SERVICES
from zenav.tools import bench_cost
from zenav.tools.bench_latency import END_TO_END
from zenav.tools.bench_live import Live
from zenav.tools.bench_proc import ProcStack


def live(robots=1, cpu=0.5, speed=1.0, overruns=0, busy=0.3, failures=(), hot=None) -> Live:
    """A 10 s window of `robots` robots, each service using `cpu` CPU s in it (`hot`: 9.5 s)."""
    ids = tuple(f"r{i + 1}" for i in range(robots))
    keys = [(r, s) for r in ids for s in SERVICES]
    counters = {k: {"msgs_in": 1000, "msgs_out": 500, "dropped_stale": 1, "overruns": overruns * (k[1] == "sim")} for k in keys}
    return Live(
        robots=ids, rate=100.0, rtf=1.0, wall=10.0, sim={r: 10.0 * speed for r in ids},
        cpu={**{k: 9.5 if k[1] == hot else cpu for k in keys}, ProcStack.ROUTER: 0.8},
        rss={**{k: 40 * 2**20 for k in keys}, ProcStack.ROUTER: 30 * 2**20},
        counters=counters, diag_span={k: 10.0 for k in keys}, chain={END_TO_END: [2.0, 3.0, 4.0]}, raw=[0.5],
        observer_cpu=0.2, machine_busy=busy, goal_failures=list(failures),
    )


def test_services_cost_per_simulated_second():
    rows = bench_cost.services(live())
    assert [r.name for r in rows] == [*SERVICES, "router"]
    sim = rows[0]
    assert sim.cpu_per_sim_s == pytest.approx(0.05) and sim.rss_mb == pytest.approx(40.0)
    assert (sim.msgs_in, sim.msgs_out) == (100.0, 50.0)
    assert rows[-1].cpu_per_sim_s == pytest.approx(0.08)


def test_a_stack_that_keeps_up():
    ld = bench_cost.load(live(robots=2))
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
    monkeypatch.setattr(bench_cost.os, "cpu_count", lambda: 2)
    ld = bench_cost.load(live(**kw))
    assert not ld.keeps_up
    assert ld.why.startswith(why), ld.why
