"""Made-up bench measurements for the bench's unit tests.

from tests.support.bench import headings, live, results, sections, summary

live(robots=2, cpu=0.5)                    # a 10 s window of a live run (bench.live.Live)
summary(Spec(trial="path"), 3.0, [1.0])    # a run's summary with these turn errors [deg] (bench.accuracy.Summary)
results()                                  # a run with every section (bench.run.Results)
headings(text) == sections("default")      # a report's headings, and those of every section
"""

from __future__ import annotations

import dataclasses
import math

from zenav.bench import cost, plan, speed
from zenav.bench.accuracy import Spec, Summary
from zenav.bench.latency import AROUND_FIX, END_TO_END, SPLIT, STAGES, configured, stages
from zenav.bench.live import Live
from zenav.bench.run import Results
from zenav.bench.scoring import Score
from zenav.bench.studies.navigator import Outcome
from zenav.services import NAMES
from zenav.stack.launcher import ProcStack

FLOOR_HOPS = {3: "three", 4: "four", 5: "five"}[len(stages(configured()))]  # the floor's heading: the configured chain's hops


def live(robots=1, cpu=0.5, speed=1.0, overruns=0, busy=0.3, failures=(), hot=None) -> Live:
    """A 10 s window of `robots` robots, each service using `cpu` CPU s in it (`hot`: 9.5 s)."""
    ids = tuple(f"r{i + 1}" for i in range(robots))
    keys = [(r, s) for r in ids for s in NAMES]
    # Every service but the sim takes the sim's clock ticks.
    counters = {
        k: {
            "msgs_in": 1000,
            "msgs_out": 500,
            "dropped_stale": 1,
            "overruns": overruns * (k[1] == "sim"),
            "clock_ticks": 200 * (k[1] != "sim"),
        }
        for k in keys
    }
    return Live(
        robots=ids,
        rate=100.0,
        rtf=1.0,
        wall=10.0,
        sim={r: 10.0 * speed for r in ids},
        cpu={**{k: 9.5 if k[1] == hot else cpu for k in keys}, ProcStack.ROUTER: 0.8},
        rss={**{k: 40 * 2**20 for k in keys}, ProcStack.ROUTER: 30 * 2**20},
        waits={k: (0.03, 1000) for k in keys},
        counters=counters,
        serve={k: {"odom": 180.0, "sensors/imu": 40.0} if k[1] == "localizer" else {} for k in keys},
        diag_span={k: 10.0 for k in keys},
        chain={END_TO_END: [2.0, 3.0, 4.0]},
        bench_cpu=0.2,
        machine_busy=busy,
        goal_failures=list(failures),
    )


def summary(spec: Spec, rtf: float, turn_deg: list[float], failures: tuple[str, ...] = (), overruns: int = 0) -> Summary:
    """A run's summary: one path goal, then a turn per entry of `turn_deg` [deg], and `failures`."""
    n = len(turn_deg)
    return Summary(
        spec=spec,
        rtf=rtf,
        pose=Score(0.01, 0.02, 0.01, 0.01, 100),
        odom=Score(0.02, 0.03, 0.02, 0.02, 100),
        errors={"point": [], "path": [0.005], "turn": [math.radians(d) for d in turn_deg]},
        durations={"point": [], "path": [12.0], "turn": [1.0 + 0.01 * i for i in range(n)]},
        goal_rmse=[0.005 + 0.0001 * i for i in range(n + 1)],
        goals=n + 1 + len(failures),
        failures=list(failures),
        overruns=overruns,
        wall=10.0 / rtf,
    )


def results() -> Results:
    """A run with every section: two live runs, costs, speed, two scenarios, a path and a kinematic study."""
    res = Results(plan.QUICK, "zenav bench --quick", 1.7e9, duration=95.0)
    base = live()
    base.chain.update({s: [0.5, 0.6, 0.7] for s in STAGES})
    base.chain[END_TO_END][:] = [2.5, 3.0, 9.0]
    res.base = base
    res.peer = live()
    res.peer.chain.update({s: [0.3, 0.4, 0.5] for s in STAGES})
    res.peer.chain[END_TO_END][:] = [1.5, 2.0, 6.0]
    for run in (base, res.peer):
        run.chain.update({f"{s}, {g}": [0.4, 0.5] for s in SPLIT for g in AROUND_FIX})
    res.busy = {0: live(), 10: live()}  # one core kept busy, at normal and at real-time priority
    res.busy[0].chain[END_TO_END][:] = [4.0, 6.0, 16.0]
    res.rates = [cost.load(base), cost.load(live(cpu=3.0, speed=0.5))]
    res.robots = [cost.load(base), cost.load(live(robots=2, overruns=3))]
    res.speed = speed.study("processes", (1.0, 3.0), (1,), lambda spec, rtf: summary(spec, rtf, [1.0, 1.2, 0.9]))
    res.rtf = 3.0
    replay = Score(0.01, 0.03, 0.005, 0.02, 500, None, 100, 3, 0)
    for scenario in ("default", "harsh"):
        s = summary(Spec(scenario=scenario, laps=1.0), 3.0, [1.0])
        s.replay.update({"ekf": replay, "dead_reckoning": dataclasses.replace(replay, rmse=0.05)})
        res.scenarios[(scenario, 1)] = s
    res.modes["ekf"] = res.scenarios[("default", 1)]
    res.paths = {"pid": [summary(Spec(trial="path", controller="pid"), 3.0, [1.0, 2.0], failures=("aborted: no progress",))]}
    res.kinematic = {"pid": [Outcome("succeeded", "", 12.0, 1.0, 0.999, math.pi / 2, 0.0)]}
    return res


def headings(text: str) -> list[str]:
    """The headings of a report, without their notes in parentheses."""
    return [line.split(" (")[0] for line in text.splitlines() if line.startswith("#")]


def sections(
    *scenarios: str, settle: bool = False, floor: bool = False, peers: bool = True, around_fix: bool = True, busy: bool = True
) -> list[str]:
    """The headings of a report with every section, its accuracy measured in `scenarios` (`settle`: and the settle
    table; `floor`: and the relay arm and the bare chain; `peers`: and the services as Zenoh peers; `around_fix`: and the localizer's
    stage around a late fix; `busy`: and the runs with a busy core)."""
    return [
        "# zenav benchmark",
        "## Targets",
        "## Latency",
        *(["### What the services add", f"### The floor: a bare chain of the same {FLOOR_HOPS} hops"] if floor else []),
        *(["### Services as Zenoh peers"] if peers else []),
        *(["### The localizer around a late fix"] if around_fix else []),
        *(["### A busy computer: the control loop at real-time priority"] if busy else []),
        "## Cost",
        "### Sensor rate",
        "### Robots on one router",
        "## Speed of simulation",
        "## Localization accuracy",
        *(f"### {s}" for s in scenarios),
        "## Navigation",
        *(["## Settle table", "### With the synthetic late VPS's pose error", "### With the camera VPS's pose error"] if settle else []),
    ]
