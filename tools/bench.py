"""`zenav bench`: accuracy, latency, cost and simulation speed of the stack in one run.

A `Plan` says how much to measure (FULL, or QUICK for CI); `run` measures it section
by section and returns `Results`, which bench_report writes as markdown and PNGs.
Every stack runs as separate processes, as `zenav up` starts them: latency and cost
at a realtime factor of 1, accuracy and navigation at the highest factor the speed
study finds within noise of realtime (capped by `Plan.rtf`). The speed study also
measures the in-process stack that the integration tests use.
"""
from __future__ import annotations

import shutil
import sys
import tempfile
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable, Optional

import msgspec

from zenav.common.scenarios import PRESETS
from zenav.services.localizer.base import MODES
from zenav.services.navigator import evaluate as nav_eval
from zenav.services.navigator.params import CONTROLLERS, Params
from zenav.tools import bench_accuracy, bench_cost, bench_live, bench_rawhop, bench_speed
from zenav.tools.bench_accuracy import Spec, Summary
from zenav.tools.bench_proc import ProcStack
from zenav.tools.plot import plot_run

SECTIONS = ("latency", "cost", "speed", "accuracy", "navigation")
RATE = 100.0  # [Hz] the reference sensor rate (scenarios.md)


@dataclass(frozen=True)
class Plan:
    """How much one bench run measures."""

    raw_window: float  # [s] the bare Zenoh hop on an idle router
    latency_window: float  # [s] one robot at 100 Hz: latency and per-process cost
    sweep_window: float  # [s] each other point of the rate and robot sweeps
    rates: tuple[float, ...]  # [Hz] sensor rates swept, one robot
    robots: tuple[int, ...]  # robot counts swept on one router, at 100 Hz
    speed_harnesses: tuple[str, ...]  # processes (what the accuracy runs use), in-process (what integration tests use)
    speed_rtfs: tuple[float, ...]  # realtime factors compared with the first (1.0)
    speed_seeds: tuple[int, ...]  # seeds of the speed study's path and turn trials
    rtf: float  # realtime factor of the accuracy runs, or the most they may use (follow_speed)
    follow_speed: bool  # lower `rtf` to the highest the speed study finds within noise of realtime
    modes: tuple[str, ...]  # localizer modes run live (default scenario, first seed)
    scenarios: tuple[str, ...]
    seeds: tuple[int, ...]  # accuracy seeds per scenario (every mode replayed on each)
    laps: float  # square laps of an accuracy run
    controllers: tuple[str, ...]
    path_seeds: tuple[int, ...]  # seed 002's path trial (then the turn sweep) per controller
    square_laps: float  # seed 003's square per controller (0: not run)
    kinematic_seeds: int  # the navigator's kinematic path trial per controller (services/navigator/evaluate.py)
    sections: tuple[str, ...] = SECTIONS
    limit: Optional[float] = None  # [s] the whole run should take less (the quick plan's CI budget)


FULL = Plan(
    raw_window=10.0, latency_window=30.0, sweep_window=20.0, rates=(50.0, 100.0, 200.0, 400.0), robots=(1, 2, 5, 10, 20),
    speed_harnesses=("processes", "in-process"), speed_rtfs=(1.0, 2.0, 3.0, 4.0, 5.0, 8.0), speed_seeds=(1, 2),
    rtf=5.0, follow_speed=True,
    modes=MODES, scenarios=tuple(PRESETS), seeds=(1, 2, 3), laps=3.0,
    controllers=CONTROLLERS, path_seeds=tuple(range(1, 11)), square_laps=3.0, kinematic_seeds=10,
)
QUICK = Plan(
    raw_window=3.0, latency_window=8.0, sweep_window=5.0, rates=(100.0,), robots=(1, 2),
    speed_harnesses=("processes",), speed_rtfs=(1.0, 3.0), speed_seeds=(1,), rtf=3.0, follow_speed=False,
    modes=("ekf",), scenarios=("default", "harsh"), seeds=(1,), laps=1.0,
    controllers=CONTROLLERS, path_seeds=(1,), square_laps=0.0, kinematic_seeds=3, limit=120.0,
)


@dataclass
class Results:
    """Everything one bench run measured (sections not run stay empty)."""

    plan: Plan
    command: str
    started: float  # [s] epoch
    duration: float = 0.0  # [s] wall, whole run
    raw_idle: list[float] = field(default_factory=list)  # [ms] bare hop, idle router
    base: Optional[bench_live.Live] = None  # one robot at 100 Hz, realtime
    peer: Optional[bench_live.Live] = None  # the same with the services as Zenoh peers
    rates: list[bench_cost.Load] = field(default_factory=list)
    robots: list[bench_cost.Load] = field(default_factory=list)
    speed: list[bench_speed.Row] = field(default_factory=list)
    rtf: float = 0.0  # the accuracy runs' realtime factor
    modes: dict[str, Summary] = field(default_factory=dict)  # live, default scenario, first seed
    scenarios: dict[tuple[str, int], Summary] = field(default_factory=dict)  # (scenario, seed) -> its run, every mode replayed
    paths: dict[str, list[Summary]] = field(default_factory=dict)  # controller -> path (and turns) runs
    squares: dict[str, Summary] = field(default_factory=dict)  # controller -> square run
    kinematic: dict[str, list[nav_eval.Outcome]] = field(default_factory=dict)  # controller -> path trials
    plots: dict[str, str] = field(default_factory=dict)  # file name in the report directory -> title


def run(plan: Plan, out: Path, command: str, say: Callable[[str], None] = lambda line: print(line, file=sys.stderr)) -> Results:
    """Measure every section of `plan`; PNGs go to `out` as they are made."""
    res = Results(plan, command, time.time())
    t0 = time.monotonic()
    logs = Path(tempfile.mkdtemp(prefix="zenav-bench-"))

    def note(text: str) -> None:
        say(f"[{time.monotonic() - t0:6.0f} s] {text}")

    note(f"service logs of the process runs in {logs} (removed if the run completes)")
    _measure(plan, res, out, logs, note)
    shutil.rmtree(logs, ignore_errors=True)
    res.duration = time.monotonic() - t0
    return res


def _measure(plan: Plan, res: Results, out: Path, logs: Path, note: Callable[[str], None]) -> None:
    """Each section of the plan in turn, into `res`."""
    if "latency" in plan.sections or "cost" in plan.sections:
        with ProcStack((), (), logs) as router:
            res.raw_idle = bench_rawhop.measure(router.endpoint, RATE, plan.raw_window)
        note(f"raw hop, idle router: {len(res.raw_idle)} samples")
        res.base = bench_live.run(1, RATE, 1.0, plan.latency_window, logs / "base")
        note(f"one robot at {RATE:g} Hz, realtime: {len(res.base.raw)} raw, {len(res.base.chain['end to end'])} chains")
        res.peer = bench_live.run(1, RATE, 1.0, plan.latency_window, logs / "peer", zenoh_mode="peer")
        note(f"the same, services as peers: {len(res.peer.chain['end to end'])} chains")
    if "cost" in plan.sections:
        base = bench_cost.load(res.base)
        for rate in plan.rates:
            res.rates.append(base if rate == RATE else _sweep_point(1, rate, plan.sweep_window, logs))
            note(f"rate {rate:g} Hz: keeps up {res.rates[-1].keeps_up} {res.rates[-1].why}")
        for n in plan.robots:
            res.robots.append(base if n == 1 else _sweep_point(n, RATE, plan.sweep_window, logs))
            note(f"{n} robots: keeps up {res.robots[-1].keeps_up} {res.robots[-1].why}")
            if res.robots[-1].why.startswith("did not come up"):
                break  # more robots would not either: the table says where it stopped
    res.rtf = plan.rtf
    runs = Runs(out, logs, res)
    if "speed" in plan.sections:
        for harness in plan.speed_harnesses:
            rows = bench_speed.study(harness, plan.speed_rtfs, plan.speed_seeds, runs.get)
            res.speed += rows
            if plan.follow_speed and harness == Spec.harness:
                res.rtf = min(plan.rtf, bench_speed.highest(rows))
            note(f"speed, {harness}: within noise up to rtf {bench_speed.highest(rows):g}")
        note(f"accuracy runs at rtf {res.rtf:g}")
    if "accuracy" in plan.sections:
        first = plan.seeds[0]
        for mode in plan.modes:  # the configured mode's run is also the default scenario's first
            spec = Spec(seed=first, mode=mode, laps=plan.laps)
            res.modes[mode] = runs.get(spec, res.rtf, plot=f"run_{mode}.png", replay=spec.mode == Spec().mode)
            note(f"mode {mode}: RMSE {res.modes[mode].pose.rmse * 100:.2f} cm")
        for scenario in plan.scenarios:
            for seed in plan.seeds:
                spec = Spec(scenario=scenario, seed=seed, laps=plan.laps)
                name = f"run_{scenario}.png" if seed == first and scenario != "default" else None
                s = res.scenarios[(scenario, seed)] = runs.get(spec, res.rtf, plot=name, replay=True)
                note(f"{scenario} seed {seed}: live RMSE {s.pose.rmse * 100:.2f} cm, every mode replayed")
    if "navigation" in plan.sections:
        for ctrl in plan.controllers:
            res.paths[ctrl] = [runs.get(Spec(seed=s, controller=ctrl, trial="path"), res.rtf) for s in plan.path_seeds]
            if plan.square_laps > 0:
                res.squares[ctrl] = runs.get(Spec(seed=plan.path_seeds[0], controller=ctrl, laps=plan.square_laps), res.rtf)
            params = msgspec.structs.replace(Params(), controller=ctrl)
            res.kinematic[ctrl] = [nav_eval.path_trial(params, PRESETS["default"], s) for s in range(plan.kinematic_seeds)]
            errs = [e for p in res.paths[ctrl] for e in p.errors["path"]]
            note(f"controller {ctrl}: path error mean {sum(errs) / max(len(errs), 1) * 100:.2f} cm over {len(errs)} runs")


def _sweep_point(robots: int, rate: float, window: float, logs: Path) -> bench_cost.Load:
    """One live run as a sweep point; stacks that do not come up in time are a point too."""
    try:
        return bench_cost.load(bench_live.run(robots, rate, 1.0, window, logs / f"robots{robots}-rate{rate:g}"))
    except TimeoutError as e:
        return bench_cost.not_started(robots, rate, str(e))


class Runs:
    """Accuracy runs by (spec, rtf), each run once: the speed study, accuracy and navigation share them."""

    def __init__(self, out: Path, logs: Path, res: Results) -> None:
        self.out, self.logs, self.res = out, logs, res
        self.done: dict[tuple[Spec, float], Summary] = {}

    def get(self, spec: Spec, rtf: float, plot: Optional[str] = None, replay: bool = False) -> Summary:
        """The run's summary, with every mode replayed on it if asked; `plot` names the PNG its first run writes."""
        key = (spec, rtf)
        if key not in self.done or (replay and not self.done[key].replay):
            r = bench_accuracy.run(spec, rtf, self.logs / f"run{len(self.done)}")
            self.done[key] = bench_accuracy.summarise(r, MODES if replay else ())
            if plot is not None:
                title = f"{spec.mode}, {spec.scenario} scenario, seed {spec.seed}"
                series = [r.trial.rec.series(topic) for topic in ("sim/truth", "odom", "pose", "vps/pose")]
                plot_run(str(self.out / plot), *series, title=title)
                self.res.plots[plot] = title
        return self.done[key]


def only(plan: Plan, sections: Optional[list[str]]) -> Plan:
    """The plan restricted to some sections (None: all)."""
    return plan if not sections else replace(plan, sections=tuple(s for s in SECTIONS if s in sections))

