"""A small slice of `zenav bench --quick`, end to end: every section measured briefly, the report written."""

from __future__ import annotations

import dataclasses

from tests.support.bench import headings, sections
from zenav.bench import plan, report
from zenav.bench.accuracy import Spec
from zenav.bench.latency import configured, present, stages
from zenav.bench.run import run

TINY = dataclasses.replace(
    plan.QUICK,
    latency_window=2.0,
    sweep_window=2.0,
    rates=(100.0,),
    robots=(1,),
    speed_rtfs=(3.0,),
    speed_harnesses=("in-process",),
    modes=("ekf",),
    scenarios=("default",),
    laps=0.25,
    controllers=(Spec().controller,),
    kinematic_seeds=1,
    settle_trials=1,
    limit=None,
)


def test_a_tiny_bench_writes_the_report_with_its_sections(tmp_path):
    lines: list[str] = []
    res = run(TINY, tmp_path, "zenav bench (test slice)", say=lines.append)
    path = report.write(res, tmp_path)
    text = path.read_text()
    assert headings(text) == sections("default", settle=True, floor=True, peers=False, busy=False)  # peers, busy: the full run's
    for png in ("latency.png", "run_ekf.png"):
        assert (tmp_path / png).stat().st_size > 10_000
    # the measurements are real: chains went through the chain's services, the robot drove and was localized
    assert len(res.base.chain["end to end"]) > 50 and res.base.sim["r1"] > 1.0
    assert res.peer is None and set(res.chains) == {"client"}  # the quick run leaves the peers to the full one
    bare = res.chains["client"]  # the bare chain's two halves, before and after the clients' run, as one
    assert len(bare.latency) > 150 and min(bare.latency) > 0.0 and bare.relay_cores > 0.0
    assert present(bare.stages) == stages(configured()) == present(res.base.chain)  # the configured chain's hops
    assert all(len(bare.stages[s]) == len(bare.latency) for s in present(bare.stages))  # stamped hop by hop, as the stack is
    assert res.robots[0].cpu_per_robot > 0.0
    ekf = res.modes["ekf"]
    assert ekf.goals == 1 and ekf.pose.n > 100 and ekf.pose.rmse < 0.10
    assert set(ekf.replay) >= {"ekf", "dead_reckoning", "overwrite", "speed_weighted", "speed_weighted_latency"}
    assert res.paths[TINY.controllers[0]][0].goals == 7  # the path, then six turns
    assert [(r.harness, r.goals) for r in res.speed] == [("in-process", 7)]
    assert any("speed" in line for line in lines)
    assert "| point 1.5 m |" in res.settle["the camera VPS's pose error"]  # one trial of every move, with each pose error
