"""`zenav bench`: accuracy, latency, cost and simulation speed of the stack in one run.

A `Plan` (bench/plan.py) says how much to measure; `run` measures it section by
section and returns `Results`, which bench/report.py writes as markdown and PNGs.
Every stack runs as separate processes, as `zenav up` starts them: latency and cost
at a realtime factor of 1, accuracy and navigation at the highest factor the speed
study finds within noise of realtime (capped by `Plan.rtf`). The speed study also
measures the in-process stack that the integration tests use.
"""

from __future__ import annotations

import shutil
import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

import msgspec

from zenav.bench import accuracy, added, board, cost, crossing, fleet, live, peers, planning, profile, settle, speed, spy
from zenav.bench import camera as camera_bench
from zenav.bench import window as window_bench
from zenav.bench.accuracy import Spec, Summary
from zenav.bench.added import Added
from zenav.bench.board import BoardRun
from zenav.bench.chain import Chain
from zenav.bench.cost import Load
from zenav.bench.fleet import HostsResult, Point
from zenav.bench.live import Live
from zenav.bench.plan import Plan
from zenav.bench.profile import Cost, Hot
from zenav.bench.speed import Row
from zenav.bench.studies import navigator as nav_eval
from zenav.common.roles import ROBOT_SERVICES
from zenav.common.scenarios import PRESETS
from zenav.services.localizer.base import MODES
from zenav.services.navigator.params import Params
from zenav.tools.plot import plot_run

RATE = 100.0  # [Hz] the reference sensor rate (scenarios.md)
CAMERA_VPS = ('vps.source="camera"', "sim.camera=true")  # the stack's VPS from the overhead camera's frames


@dataclass
class Results:
    """Everything one bench run measured (sections not run stay empty)."""

    plan: Plan
    command: str
    started: float  # [s] epoch
    duration: float = 0.0  # [s] wall, whole run
    chains: dict[str, Chain] = field(default_factory=dict)  # Zenoh mode -> the bare chain of its hops, beside the stack's runs
    added: dict[str, Added] = field(default_factory=dict)  # deployment -> what the robot services add (bench/added.py)
    plain: Live | None = None  # the cost section's run: the stack alone on its router
    camera_vps: Live | None = None  # the same with the camera VPS (the sim renders the overhead camera, the vps reads it)
    base: Live | None = None  # one robot at 100 Hz, realtime, its runs' chains pooled (beside its relay arm and the bare chain)
    peer: Live | None = None  # the same with the services as Zenoh peers
    composed: Live | None = None  # the same with the robot's services composed in one process
    busy: dict[int, Live] = field(default_factory=dict)  # the control loop's priority (0: normal) -> the run with one core kept busy
    busy_refused: str = ""  # why the busy runs were not made (real-time priority refused)
    rates: list[Load] = field(default_factory=list)
    robots: list[Load] = field(default_factory=list)
    boards: dict[str, BoardRun] = field(default_factory=dict)  # deployment -> the robot profile and its camera on the emulated board
    speed: list[Row] = field(default_factory=list)
    rtf: float = 0.0  # the accuracy runs' realtime factor
    modes: dict[str, Summary] = field(default_factory=dict)  # live, default scenario, first seed
    scenarios: dict[tuple[str, int], Summary] = field(default_factory=dict)  # (scenario, seed) -> its run, every mode replayed
    paths: dict[str, list[Summary]] = field(default_factory=dict)  # controller -> path (and turns) runs
    squares: dict[str, Summary] = field(default_factory=dict)  # controller -> square run
    kinematic: dict[str, list[nav_eval.Outcome]] = field(default_factory=dict)  # controller -> path trials
    plots: dict[str, str] = field(default_factory=dict)  # file name in the report directory -> title
    costs: dict[str, Cost] = field(default_factory=dict)  # service -> CPU over the profile run (bench/profile.py)
    costs_paced: dict[str, Cost] = field(default_factory=dict)  # the same, one wall period between steps (as deployed)
    relays: tuple[float, float] = (0.0, 0.0)  # [us] a bare chain relay's CPU per message: back to back, paced
    hot: dict[str, list[Hot]] = field(default_factory=dict)  # service -> its costliest functions
    spied: spy.Deployed | str | None = None  # the robot's service processes sampled as deployed, or why they were not
    fleet: list[Point] = field(default_factory=list)  # the router under N robots' traffic
    hosts: HostsResult | str | None = None  # the fleet over several hosts, or why it was not run
    settle: dict[str, str] = field(default_factory=dict)  # pose error -> the settle table (markdown)
    planning: list[str] = field(default_factory=list)  # the planning section's tables (markdown lines)
    cameras: dict[str, camera_bench.Measured] = field(default_factory=dict)  # camera -> its frames timed and read
    camera_runs: dict[str, list[tuple[Summary, Summary]]] = field(default_factory=dict)  # trial -> (synthetic, camera) per seed
    peers: dict[str, list[peers.Compared]] = field(default_factory=dict)  # stream -> zenav beside WPILib's estimator on it
    window: window_bench.Compared | None = None  # a 1280x720 camera: the windowed search against the whole frame


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
    _measure_live(plan, res, logs, note)
    _measure_runs(plan, res, out, logs, note)


def _measure_live(plan: Plan, res: Results, logs: Path, note: Callable[[str], None]) -> None:
    """The sections measured on live stacks in real time (latency, cost, profile, fleet), into `res`."""
    if "latency" in plan.sections:
        _latency(plan, res, logs, note)
    if "cost" in plan.sections:
        res.plain = base = live.run(1, RATE, 1.0, plan.latency_window, logs / "plain")  # the stack alone on its router
        note(f"one robot at {RATE:g} Hz, realtime, alone: {len(base.chain['end to end'])} chains")
        res.camera_vps = live.run(1, RATE, 1.0, plan.sweep_window, logs / "camera-vps", sets=CAMERA_VPS)
        note(f"one robot at {RATE:g} Hz with the camera VPS: {len(res.camera_vps.chain['end to end'])} chains")
        one = cost.load(base)
        for rate in plan.rates:
            res.rates.append(one if rate == RATE else _sweep_point(1, rate, plan.sweep_window, logs))
            note(f"rate {rate:g} Hz: keeps up {res.rates[-1].keeps_up} {res.rates[-1].why}")
        for n in plan.robots:
            res.robots.append(one if n == 1 else _sweep_point(n, RATE, plan.sweep_window, logs))
            note(f"{n} robots: keeps up {res.robots[-1].keeps_up} {res.robots[-1].why}")
            if res.robots[-1].why.startswith("did not come up"):
                break  # more robots would not either: the table says where it stopped
        if plan.board_window:
            res.boards = board.measure(plan.board_window, logs)
            for name, cores, goal in board.budget(res.boards):
                note(f"robot computer: {cores:.3f} core ({name}; goal {goal:g})")
    if "profile" in plan.sections:
        res.costs, res.costs_paced, res.relays = profile.measure_both(plan.profile_seconds)
        res.hot = profile.profile(min(plan.profile_seconds, 5.0))
        robot = sum(res.costs[n].cores(profile.RATE) for n in ROBOT_SERVICES)
        note(f"profile: the robot's services take {robot:.3f} of a core at {profile.RATE:g} Hz")
        res.spied = spy.refused() or spy.deployed(plan.spy_seconds, logs)
        note(f"profile as deployed: {res.spied if isinstance(res.spied, str) else 'sampled'}")
    if "fleet" in plan.sections:
        res.fleet = fleet.router_load(plan.fleet_robots, plan.fleet_window, logs)
        note(f"router load: {', '.join(f'{p.robots}: {p.per_robot:.3f} cores/robot' for p in res.fleet)}")
        if plan.fleet_hosts:
            res.hosts = fleet.netns_available() or fleet.hosts(plan.fleet_hosts, log_dir=logs)
            note(f"fleet over {plan.fleet_hosts} hosts: {res.hosts}")


def _measure_runs(plan: Plan, res: Results, out: Path, logs: Path, note: Callable[[str], None]) -> None:
    """The sections measured on simulated runs and studies (speed, accuracy, navigation, settle, planning, camera),
    into `res`."""
    res.rtf = plan.rtf
    runs = Runs(out, logs, res)
    if "speed" in plan.sections:
        for harness in plan.speed_harnesses:
            rows = speed.study(harness, plan.speed_rtfs, plan.speed_seeds, runs.get)
            res.speed += rows
            if plan.follow_speed and harness == Spec.harness:
                res.rtf = min(plan.rtf, speed.highest(rows))
            note(f"speed, {harness}: within noise up to rtf {speed.highest(rows):g}")
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
    if "settle" in plan.sections:
        res.settle["the synthetic late VPS's pose error"] = settle.table(plan.settle_trials)
        camera = settle.table(plan.settle_trials, settle.CAMERA_SIGMA, heading_sigma=settle.CAMERA_HEADING_SIGMA)
        res.settle["the camera VPS's pose error"] = camera
        note(f"settle table: {plan.settle_trials} trials per move, two pose errors")
    if "planning" in plan.sections:
        res.planning = planning.report(plan.planning_pairs, plan.planning_drives) + ["", *crossing.report(plan.crossing_runs)]
        note(
            f"planning: {plan.planning_pairs} pairs and {plan.planning_drives} driven goals per layout; "
            f"{plan.crossing_runs} runs of crossing robots per case"
        )
    if "camera" in plan.sections:
        for name, cfg in camera_bench.CAMERAS.items():
            res.cameras[name] = r = camera_bench.measure(cfg, plan.camera_frames)
            note(f"camera {name}: detect + locate p50 {r.timing['detect'].wall[0]:.1f} ms, position p95 {r.accuracy.pos_mm[1]:.2f} mm")
        res.window = window_bench.measure(plan.camera_frames)
        note(res.window.line())
        specs = {f"{sc}, square": [Spec(scenario=sc, seed=plan.seeds[0], laps=plan.laps)] for sc in plan.camera_scenarios}
        specs["default, path"] = [Spec(seed=s, trial="path") for s in plan.camera_path_seeds]
        rtf = plan.camera_rtf
        for trial, group in specs.items():
            res.camera_runs[trial] = [(runs.get(s, rtf), runs.get(replace(s, vps="camera"), rtf)) for s in group]
            cam = [c.pose.rmse for _, c in res.camera_runs[trial]]
            note(f"camera VPS, {trial}: pose RMSE {', '.join(f'{x * 100:.2f}' for x in cam)} cm")

    if "peers" in plan.sections:
        _peers(plan, res, logs, note)


def _peers(plan: Plan, res: Results, logs: Path, note: Callable[[str], None]) -> None:
    """WPILib's estimator beside zenav's localizer: the world model's streams over seeds, then the live stack's."""
    for name, runs in peers.study(plan.wpilib_scenarios, plan.wpilib_seeds).items():
        res.peers[f"{name}, synthetic VPS, world model, seeds {', '.join(map(str, plan.wpilib_seeds))}"] = runs
        note(f"peers, {name}, world model: WPILib's best / zenav {statistics.fmean(c.ratio for c in runs):.1f}x")
    rtfs = {"synthetic": res.rtf, "camera": plan.camera_rtf}
    res.peers.update(peers.live(plan.wpilib_scenarios, plan.wpilib_vps, plan.seeds[0], plan.laps, rtfs, logs, note))


def _latency(plan: Plan, res: Results, logs: Path, note: Callable[[str], None]) -> None:
    """Each deployment's latency runs, the deployments in turn run after run: the stack, its relay arm and (separate
    processes) the bare chain of its hops over the same window of each run (live.run's `beside`)."""
    deployments: dict[str, tuple[str, tuple[str, ...]]] = {"clients": ("client", ())}
    if plan.peers:
        deployments["peers"] = ("peer", ())
    if plan.compose:
        deployments["composed"] = ("client", plan.compose)
    runs: dict[str, list[Live]] = {name: [] for name in deployments}
    for i in range(plan.latency_runs):
        for name, (mode, compose) in deployments.items():
            r = live.run(1, RATE, 1.0, plan.latency_window, logs / f"{name}-{i}", zenoh_mode=mode, compose=compose, beside=True)
            runs[name].append(r)
            arm = len(r.arm["end to end"]) if r.arm is not None else 0
            note(f"latency, {name}, run {i + 1}: {len(r.chain['end to end'])} chains, relay arm {arm}")
    for name, lives in runs.items():
        arms = [r.arm for r in lives if r.arm is not None]
        res.added[name] = added.of_runs([r.chain for r in lives], arms)
        note(res.added[name].line(name))
    pooled = {name: replace(lives[0], chain=added.pooled([r.chain for r in lives])) for name, lives in runs.items()}
    res.base, res.peer, res.composed = pooled["clients"], pooled.get("peers"), pooled.get("composed")
    for name, (mode, _) in deployments.items():
        bare = [r.bare for r in runs[name] if r.bare is not None]
        if bare:
            res.chains[mode] = Chain.pooled(bare)
    if plan.busy:
        _busy(plan, res, logs, note)


def _busy(plan: Plan, res: Results, logs: Path, note: Callable[[str], None]) -> None:
    """The clients' latency run with one core kept busy by another program: at normal priority, then with the
    control loop at real-time priority (where the host allows it)."""
    refused = live.realtime_refused(live.REALTIME)
    if refused is not None:
        res.busy_refused = refused
        note(f"one core busy: not run ({refused})")
        return
    for priority in (0, live.REALTIME):
        with live.busy_core():
            res.busy[priority] = r = live.run(1, RATE, 1.0, plan.latency_window, logs / f"busy-{priority}", realtime=priority)
        note(f"one core busy, real-time priority {priority}: {len(r.chain['end to end'])} chains")


def _sweep_point(robots: int, rate: float, window: float, logs: Path) -> Load:
    """One live run as a sweep point; stacks that do not come up in time are a point too."""
    try:
        return cost.load(live.run(robots, rate, 1.0, window, logs / f"robots{robots}-rate{rate:g}"))
    except TimeoutError as e:
        return cost.not_started(robots, rate, str(e))


class Runs:
    """Accuracy runs by (spec, rtf), each run once: the speed study, accuracy and navigation share them."""

    def __init__(self, out: Path, logs: Path, res: Results) -> None:
        self.out, self.logs, self.res = out, logs, res
        self.done: dict[tuple[Spec, float], Summary] = {}

    def get(self, spec: Spec, rtf: float, plot: str | None = None, replay: bool = False) -> Summary:
        """The run's summary, with every mode replayed on it if asked; `plot` names the PNG its first run writes."""
        key = (spec, rtf)
        if key not in self.done or (replay and not self.done[key].replay):
            r = accuracy.run(spec, rtf, self.logs / f"run{len(self.done)}")
            self.done[key] = accuracy.summarise(r, MODES if replay else ())
            if plot is not None:
                title = f"{spec.mode}, {spec.scenario} scenario, seed {spec.seed}"
                rec = r.trial.rec
                series = (rec.series("sim/truth"), rec.series("odom"), rec.series("pose"), rec.series("vps/pose"))
                plot_run(str(self.out / plot), *series, title=title)
                self.res.plots[plot] = title
        return self.done[key]
