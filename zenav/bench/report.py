"""The bench report: the machine and versions, then every section as markdown tables,
with the PNGs beside it (`report.md` in the output directory)."""

from __future__ import annotations

import datetime
import importlib.metadata
import os
import platform
import subprocess
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from zenav.bench import board, cost, peers, tables
from zenav.bench.added import QS
from zenav.bench.latency import END_TO_END, Stats, present
from zenav.bench.profile import RATE
from zenav.bench.run import Results
from zenav.bench.speed import highest_by_harness
from zenav.bench.tables import TARGET_ADDED, fmt, ratios, table
from zenav.common.roles import ROBOT_SERVICES

TARGET_P50, TARGET_P99 = 3.0, 8.0  # [ms] end to end at 100 Hz
TARGET_CPU = 0.30  # [CPU s per simulated s] the whole stack at 100 Hz, whatever VPS runs
TARGET_ROBOT_CPU = 0.15  # [CPU s per simulated s] the four services a real robot runs, at 100 Hz
STACK_COLOURS = ("tab:blue", "tab:green", "tab:purple")  # the latency histogram: clients, peers, composed
BARE_COLOURS = {"client": "tab:gray", "peer": "tab:orange"}  # ... and the bare chain per Zenoh mode
PACKAGES = ("zenav", "eclipse-zenoh", "numpy", "msgspec", "matplotlib")


def machine() -> list[str]:
    """Lines naming the host: CPU model, cores, memory, kernel, load."""
    model = "unknown"
    with open("/proc/cpuinfo") as f:
        for line in f:
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    with open("/proc/meminfo") as f:
        mem_kb = int(f.readline().split()[1])
    load = ", ".join(f"{x:.2f}" for x in os.getloadavg())
    return [
        f"- machine: {model}, {os.cpu_count()} cores, {mem_kb / 2**20:.1f} GiB memory, "
        f"{platform.system()} {platform.release()}; load average at the end {load}",
    ]


def versions() -> str:
    """Python and package versions, and the source revision."""
    found = [f"Python {platform.python_version()}"]
    for name in PACKAGES:
        try:
            found.append(f"{name} {importlib.metadata.version(name)}")
        except importlib.metadata.PackageNotFoundError:
            found.append(f"{name} (not installed)")
    try:
        rev = subprocess.run(
            ["git", "describe", "--always", "--dirty"], cwd=Path(__file__).parent, capture_output=True, text=True, timeout=10
        ).stdout.strip()
    except OSError:
        rev = ""
    return ", ".join(found) + f"; source {rev or 'unknown (not a git checkout)'}"


def latency_plot(path: Path, res: Results) -> None:
    """Histogram of end-to-end latency, the stack's runs beside the bare chains, log scale, with the targets."""
    fig = Figure(figsize=(10, 4.5), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    runs = (("stack, clients", res.base), ("stack, peers", res.peer), ("stack, composed", res.composed))
    series = [(label, live.chain[END_TO_END], colour) for (label, live), colour in zip(runs, STACK_COLOURS) if live is not None]
    series += [(f"bare chain, {mode}s", c.latency, BARE_COLOURS[mode]) for mode, c in res.chains.items()]
    values = [v for _, s, _ in series for v in s if v > 0]
    bins = np.geomspace(max(min(values, default=0.01), 0.01), max(max(values, default=1.0), 1.0) * 1.01, 60).tolist()
    for label, s, colour in series:
        if len(s):
            st = Stats.of(s)
            ax.hist(s, bins=bins, histtype="step", lw=1.6, color=colour, label=f"{label}: p50 {st.p50:.2f}, p99 {st.p99:.2f} ms")
    for x, name in ((TARGET_P50, "p50 target"), (TARGET_P99, "p99 target")):
        ax.axvline(x, color="tab:red", ls="--", lw=1)
        ax.text(x, ax.get_ylim()[1] * 0.95, f" {name}", color="tab:red", va="top", fontsize="small")
    ax.set(xscale="log", xlabel="latency [ms]", ylabel="samples", title="sensor sample to wheel command, realtime, 100 Hz")
    ax.grid(alpha=0.3)
    ax.legend(loc="center right", fontsize="small")  # below the targets' labels
    fig.savefig(path, dpi=100)


def _targets(res: Results) -> list[str]:
    rows, notes = [], []
    if res.base is not None:
        e2e = Stats.of(res.base.chain[END_TO_END])
        rows.append(["end to end p50 at 100 Hz", f"<= {TARGET_P50:g} ms", f"{fmt(e2e.p50)} ms", _met(e2e.p50 <= TARGET_P50)])
        rows.append(["end to end p99 at 100 Hz", f"<= {TARGET_P99:g} ms", f"{fmt(e2e.p99)} ms", _met(e2e.p99 <= TARGET_P99)])
        bare = res.chains.get("client")
        if (e2e.p50 > TARGET_P50 or e2e.p99 > TARGET_P99) and bare is not None:
            floor = Stats.of(bare.latency)
            extra = e2e.p50 - floor.p50
            rest = (
                f"the services' own work and queueing add the other {fmt(extra)} ms at p50"
                if extra >= 0.0
                else f"at p50 the stack took {fmt(-extra)} ms less than they did: "
                "the hops and the host's load, not the services' work, set its latency"
            )
            stages = present(res.base.chain)
            notes.append(
                f"Latency: a sample crosses {len(stages)} hops (sim, {', '.join(stages[1:])}, to the observer). The "
                f"same {len(stages)} hops with no service work took {fmt(floor.p50)} ms at p50 and {fmt(floor.p99)} ms at p99 "
                f"in the same windows; {rest}. The machine was {res.base.machine_busy:.0%} busy (every process on it) during the window."
            )
        costs = cost.services(res.plain or res.base)
        cpu = sum(c.cpu_per_sim_s for c in costs)
        measured = f"{fmt(cpu, 3)} CPU s per simulated s"
        rows.append(["whole stack CPU at 100 Hz", f"<= {TARGET_CPU:g} core", measured, _met(cpu <= TARGET_CPU)])
        if res.camera_vps is not None:
            ccpu = sum(c.cpu_per_sim_s for c in cost.services(res.camera_vps))
            row = ["whole stack CPU at 100 Hz, camera VPS", f"<= {TARGET_CPU:g} core", f"{fmt(ccpu, 3)} CPU s per simulated s"]
            rows.append([*row, _met(ccpu <= TARGET_CPU)])
        robot = sum(c.cpu_per_sim_s for c in costs if c.name in ROBOT_SERVICES)
        rows.append(
            [
                f"{', '.join(ROBOT_SERVICES)} CPU at 100 Hz",
                f"<= {TARGET_ROBOT_CPU:g} core",
                f"{fmt(robot, 3)} CPU s per simulated s",
                _met(robot <= TARGET_ROBOT_CPU),
            ]
        )
        if res.peer is not None:
            pe2e = Stats.of(res.peer.chain[END_TO_END])
            pcpu = sum(c.cpu_per_sim_s for c in cost.services(res.peer))
            rows.append(["end to end p50, services as peers", f"<= {TARGET_P50:g} ms", f"{fmt(pe2e.p50)} ms", _met(pe2e.p50 <= TARGET_P50)])
            rows.append(["end to end p99, services as peers", f"<= {TARGET_P99:g} ms", f"{fmt(pe2e.p99)} ms", _met(pe2e.p99 <= TARGET_P99)])
            rows.append(
                [
                    "whole stack CPU, services as peers",
                    f"<= {TARGET_CPU:g} core",
                    f"{fmt(pcpu, 3)} CPU s per simulated s",
                    _met(pcpu <= TARGET_CPU),
                ]
            )
        rows += _ratio_rows(res)
        if cpu > TARGET_CPU:
            top = sorted(costs, key=lambda c: -c.cpu_per_sim_s)[:3]
            notes.append("CPU: the largest are " + ", ".join(f"{c.name} {fmt(c.cpu_per_sim_s, 3)}" for c in top) + ".")
        if "client" in res.chains:
            notes.append(_floor_note(costs, res.chains["client"].relay_cores))
    for name, cores, goal in board.budget(res.boards):
        rows.append([f"robot computer, {name} (router aside)", f"<= {goal:g} core", f"{fmt(cores, 3)} core", _met(cores <= goal)])
    if res.robots:
        kept = [ld.robots for ld in res.robots if ld.keeps_up]
        rows.append(["robots one router keeps up with (100 Hz)", "-", str(max(kept, default=0)), "-"])
    if res.speed:
        best = ", ".join(f"{h} {v:g}" for h, v in highest_by_harness(res.speed).items())
        rows.append(["highest realtime factor within noise of realtime", "-", best, "-"])
    if res.plan.limit is not None:
        rows.append(["whole bench run", f"< {res.plan.limit:g} s", f"{res.duration:.0f} s", _met(res.duration < res.plan.limit)])
    return table(["target", "goal", "measured", "met"], rows) + [line for note in notes for line in ("", note)]


def _floor_note(costs: list[cost.ServiceCost], relay: float) -> str:
    """What the CPU goals stand on on this machine: the stack's messages at a bare relay's price each."""
    robot = [c for c in costs if c.name in ROBOT_SERVICES]
    stack = [c for c in costs if c.name != "router"]
    n_in, n_out, ticks = sum(c.msgs_in for c in robot), sum(c.msgs_out for c in robot), sum(c.ticks_in for c in robot)
    with_ticks = f" (and {ticks:.0f} sim clock ticks)" if ticks else ""
    return (
        f"CPU floor: a bare relay (one topic in and out at {RATE:g} Hz) took {fmt(relay, 3)} of a core in this run. At its "
        f"price per message, the {n_in:.0f} messages a second the robot's services take{with_ticks} and the {n_out:.0f} they send "
        f"would cost {fmt(cost.transport_floor(robot, relay, RATE), 3)} of a core with no work of theirs (goal "
        f"{TARGET_ROBOT_CPU:g}), every stack process's but the router's {fmt(cost.transport_floor(stack, relay, RATE), 3)} "
        f"(goal for the whole stack, the router's {fmt(sum(c.cpu_per_sim_s for c in costs if c.name == 'router'), 3)} "
        f"included: {TARGET_CPU:g})."
    )


def _ratio_rows(res: Results) -> list[list[str]]:
    """What the services add (goals), then end to end over the bare chain beside it (no goal), per deployment."""
    rows = []
    for name, a in res.added.items():
        for q, goal, value, low, high in zip(QS, TARGET_ADDED, a.added, a.low, a.high):
            measured = f"{fmt(value)} ms ({fmt(low)} to {fmt(high)})"
            rows.append([f"services' added latency p{q:g}, {name}", f"<= {goal:g} ms", measured, _met(value <= goal)])
    runs = (("clients", res.base, "client"), ("services as peers", res.peer, "peer"))
    for name, live, mode in runs:
        if live is None or mode not in res.chains:
            continue
        p50, p99 = ratios(live.chain[END_TO_END], res.chains[mode].latency)
        rows.append([f"end to end / bare chain of its hops, {name}, same windows", "-", f"p50 {fmt(p50)}x, p99 {fmt(p99)}x", "-"])
    return rows


def _met(ok: bool) -> str:
    return "yes" if ok else "**no**"


def write(res: Results, out: Path) -> Path:
    """Write report.md (and the latency histogram) into `out`; returns the report's path."""
    out.mkdir(parents=True, exist_ok=True)
    started = datetime.datetime.fromtimestamp(res.started).astimezone().isoformat(timespec="seconds")
    lines = [
        "# zenav benchmark",
        "",
        f"- command: `{res.command}`",
        f"- started {started}, took {res.duration:.0f} s ({res.duration / 60:.1f} min)",
        *machine(),
        f"- software: {versions()}",
        f"- seeds: accuracy {list(res.plan.seeds)}, speed study {list(res.plan.speed_seeds)}, "
        f"path trial {list(res.plan.path_seeds)}, kinematic path trial 0..{res.plan.kinematic_seeds - 1}",
        "",
        "The machine is shared and noisy: compare figures within this report (ratios, and distributions "
        "from the same run), not across reports.",
        "",
        "## Targets",
        "",
        *_targets(res),
    ]
    if res.base is not None:
        latency_plot(out / "latency.png", res)
        lines += ["", *tables.latency(res), "", "![latency histogram](latency.png)"]
    if res.rates or res.robots:
        lines += ["", *tables.cost(res)]
    if res.speed:
        lines += ["", *tables.speed(res)]
    if res.modes or res.scenarios:
        lines += ["", *tables.accuracy(res)]
    if res.paths:
        lines += ["", *tables.navigation(res)]
    if res.settle:
        lines += ["", *tables.settle(res)]
    if res.planning:
        lines += ["", "## Planning", "", *res.planning]
    if res.cameras or res.camera_runs or res.window is not None:
        lines += ["", *tables.camera(res)]
    if res.peers:
        lines += ["", "## WPILib's pose estimator on the same streams", "", peers.INTRO, "", *peers.lines(res.peers)]
    if res.costs:
        lines += ["", *tables.profile(res)]
    if res.fleet:
        lines += ["", *tables.fleet(res)]
    path = out / "report.md"
    path.write_text("\n".join(lines) + "\n")
    return path
