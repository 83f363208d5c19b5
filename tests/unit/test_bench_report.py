"""The bench report from made-up results: every section, the targets' verdicts, the plot."""
from __future__ import annotations

import dataclasses
import math

from tests.unit.test_bench_cost import live
from tests.unit.test_bench_speed import summary
from zenav.services.localizer.evaluate import Score as ReplayScore
from zenav.services.navigator.evaluate import Outcome
from zenav.tools import bench, bench_cost, bench_report, bench_speed
from zenav.tools.bench_accuracy import Spec
from zenav.tools.bench_latency import END_TO_END, STAGES


def results() -> bench.Results:
    res = bench.Results(bench.QUICK, "zenav bench --quick", 1.7e9, duration=95.0)
    base = live()
    base.chain.update({s: [0.5, 0.6, 0.7] for s in STAGES})
    base.chain[END_TO_END][:] = [2.5, 3.0, 9.0]
    res.base, res.raw_idle = base, [0.3, 0.4]
    res.peer = live()
    res.peer.chain.update({s: [0.3, 0.4, 0.5] for s in STAGES})
    res.peer.chain[END_TO_END][:] = [1.5, 2.0, 6.0]
    res.rates = [bench_cost.load(base), bench_cost.load(live(cpu=3.0, speed=0.5))]
    res.robots = [bench_cost.load(base), bench_cost.load(live(robots=2, overruns=3))]
    res.speed = bench_speed.study("processes", (1.0, 3.0), (1,), lambda spec, rtf: summary(spec, rtf, [1.0, 1.2, 0.9]))
    res.rtf = 3.0
    replay = ReplayScore(0.01, 0.03, 0.005, 0.02, None, 100, 3, 0)
    for scenario in ("default", "harsh"):
        s = summary(Spec(scenario=scenario, laps=1.0), 3.0, [1.0])
        s.replay.update({"ekf": replay, "dead_reckoning": dataclasses.replace(replay, rmse=0.05)})
        res.scenarios[(scenario, 1)] = s
    res.modes["ekf"] = res.scenarios[("default", 1)]
    res.paths = {"pid": [summary(Spec(trial="path", controller="pid"), 3.0, [1.0, 2.0], failures=("aborted: no progress",))]}
    res.kinematic = {"pid": [Outcome("succeeded", "", 12.0, 1.0, 0.999, math.pi / 2, 0.0)]}
    return res


def test_every_section_and_target_is_written(tmp_path):
    path = bench_report.write(results(), tmp_path)
    text = path.read_text()
    headings = [line for line in text.splitlines() if line.startswith("#")]
    assert [h.split(" (")[0] for h in headings] == [
        "# zenav benchmark", "## Targets", "## Latency", "### Services as Zenoh peers", "## Cost", "### Sensor rate", "### Robots on one router",
        "## Speed of simulation", "## Localization accuracy", "### default", "### harsh", "## Navigation",
    ]
    assert "| end to end p50 at 100 Hz | <= 3 ms | 3.00 ms | yes |" in text
    assert "| end to end p99 at 100 Hz | <= 8 ms | 8.88 ms | **no** |" in text
    assert "| whole bench run | < 120 s | 95 s | yes |" in text
    assert "| end to end p50, services as peers | <= 3 ms | 2.00 ms | yes |" in text
    assert "| router, services as peers |" in text
    assert "cores" in text and "GiB memory" in text and "eclipse-zenoh" in text and "`zenav bench --quick`" in text
    assert "at 2 it stopped keeping up" in text
    assert "aborted: no progress" in text  # failures are named
    assert (tmp_path / "latency.png").stat().st_size > 10_000


def test_an_empty_run_writes_only_the_header(tmp_path):
    res = bench.Results(bench.only(bench.FULL, ["speed"]), "zenav bench --only speed", 1.7e9)
    text = bench_report.write(res, tmp_path).read_text()
    assert "## Targets" in text and "## Latency" not in text and "## Navigation" not in text
