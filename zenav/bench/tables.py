"""The report's sections as markdown lines, from the bench's results."""

from __future__ import annotations

import math
import os
import statistics
from collections.abc import Sequence
from typing import TYPE_CHECKING

from zenav.bench import added as added_bench
from zenav.bench import board
from zenav.bench import camera as camera_bench
from zenav.bench.accuracy import Summary
from zenav.bench.chain import Chain
from zenav.bench.cost import Load, ServiceCost, services
from zenav.bench.latency import AROUND_FIX, CHAIN, END_TO_END, NEAR_FIX, SPLIT, STAGES, Stats
from zenav.bench.live import Live
from zenav.bench.profile import RATE
from zenav.bench.scoring import summary
from zenav.bench.speed import METRICS, highest_by_harness
from zenav.bench.spy import Deployed
from zenav.common.config import Camera
from zenav.common.roles import ROBOT_SERVICES
from zenav.common.scenarios import HEADINGS, PATH
from zenav.services.driver.protocol import BAUD
from zenav.services.driver.service import DriverConfig
from zenav.services.vps.track import FULL_PERIOD

if TYPE_CHECKING:
    from zenav.bench.run import Results

TARGET_ADDED = (0.25, 1.0)  # [ms] what the robot services add to end to end at p50, p99 (bench/added.py)
SEED_002_ROBOT = "mean 11.4 / sd 3.9 cm with a 5 cm stopping threshold"  # the seed's real robot (scenarios.md)


def fmt(x: float, digits: int = 2) -> str:
    return "-" if math.isnan(x) else f"{x:.{digits}f}"


def pct(x: float) -> str:
    return "-" if math.isnan(x) else f"{x:.0%}"


def table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> list[str]:
    """A markdown table."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return lines + ["| " + " | ".join(map(str, r)) + " |" for r in rows]


def _stats_row(name: str, values: Sequence[float]) -> list[str]:
    st = Stats.of(values)
    return [name, str(st.n), fmt(st.p50), fmt(st.p90), fmt(st.p99), fmt(st.max)]


def _failures(labelled) -> list[str]:
    """A line per run with goals that did not succeed, and why."""
    out = [f"- {label}: {'; '.join(s.failures)}" for label, s in labelled if s.failures]
    return ["", "Goals that did not succeed:", *out] if out else []


# ------------------------------------------------------------------ latency
def _chain_rows(chain: dict[str, list[float]]) -> list[list[str]]:
    """A row per stage of the sensor-to-wheel chain, then end to end."""
    return [_stats_row(s, chain[s]) for s in STAGES] + [_stats_row(f"**{END_TO_END}**", chain[END_TO_END])]


def _composed_rows(chain: dict[str, list[float]]) -> list[list[str]]:
    """The chain's rows composed: delivery, the robot's services as one stage (from the encoder sample's arrival
    to the wheel command's: end to end less delivery, sample by sample), end to end."""
    delivery, e2e = chain[STAGES[0]], chain[END_TO_END]
    services = [e - d for e, d in zip(e2e, delivery)]
    name = f"{STAGES[1]} to {STAGES[-1]}, in one process"
    return [_stats_row(STAGES[0], delivery), _stats_row(name, services), _stats_row(f"**{END_TO_END}**", e2e)]


def latency(res: Results) -> list[str]:
    """The latency section (none without the one-robot run)."""
    base = res.base
    if base is None:
        return []
    biggest = max(STAGES[1:], key=lambda s: Stats.of(base.chain[s]).p50)
    return [
        "## Latency",
        "",
        f"One robot, every service its own process, one router, realtime, {base.rate:g} Hz, {base.wall:.0f} s window "
        "while the navigator drives the square. Per encoder sample t: the sim's wall-clock stamp of t, then the wall "
        "arrival of `sensors/encoders`, `odom`, `pose`, `cmd_vel` and `motors/wheels` of that t at an observer "
        "process. `delivery` is sim to a subscriber (one hop); each service's row is the hop into it plus its work; "
        "they add up to end to end (now - t on `motors/wheels`). Nothing else of the bench runs in the window. [ms]",
        "",
        *table(["stage", "n", "p50", "p90", "p99", "max"], _chain_rows(base.chain)),
        "",
        f"Largest service stage at p50: {biggest}. Machine busy during the window: {base.machine_busy:.0%} of "
        f"{os.cpu_count()} cores (everything running on it, not only the stack).",
        *_serve(base),
        *_added(res),
        *_floor(res),
        *_peer_latency(res, base),
        *_composed_latency(res, base),
        *_around_fix(res),
        *_busy(res, base),
    ]


def _added(res: Results) -> list[str]:
    """What the robot services add: each deployment's runs against their relay arms (bench/added.py)."""
    if not res.added:
        return []
    return [
        "",
        "### What the services add",
        "",
        "In every latency run, on the same router over the same window, the relay arm: the same stack under another "
        "robot id with odometry, localizer, navigator and motor replaced in place by relays (bench/arm.py: each "
        "decodes its input and publishes an output of the service's type stamped with the input's t; composed, one "
        "relay process publishes the four). Its end to end is the floor of the stack's with the same hop count; the "
        "stack's less the arm's is what the services' own work adds. The deployments' runs interleave; the samples of "
        f"each arm are pooled over the runs, and the interval is a {added_bench.LEVEL:.0%} bootstrap (bench/added.py). "
        f"Goals: p50 <= {TARGET_ADDED[0]:g} ms, p99 <= {TARGET_ADDED[1]:g} ms.",
        "",
        *[f"- {a.line(name)}" for name, a in res.added.items()],
    ]


def _serve(live: Live) -> list[str]:
    """What serving one message of each input took each robot service in its own process (its diag `serve`)."""
    first = live.robots[0]
    rows = [[name, topic, fmt(us, 0)] for name in ROBOT_SERVICES for topic, us in sorted(live.serve.get((first, name), {}).items())]
    if not rows:
        return []
    return [
        "",
        "Serving one message in the service's own process (diag `serve`, the window's last second: decoding it, "
        "the handler, publishing what it returned), mean [us]. The `profile` section times the same work with "
        "every service in one process, back to back and paced: deployed, each message finds the process cold.",
        "",
        *table(["service", "input", "us"], rows),
    ]


def _busy(res: Results, base: Live) -> list[str]:
    """The clients' run again with one core kept busy, at normal priority and with the control loop at real-time."""
    title = ["", "### A busy computer: the control loop at real-time priority", ""]
    if res.busy_refused:
        return [*title, f"Not run: real-time priority refused on this host ({res.busy_refused})."]
    if not res.busy:
        return []
    runs = [("idle, normal priority (the run above)", base)]
    runs += [(f"one core busy, {f'real-time priority {p}' if p else 'normal priority'}", r) for p, r in sorted(res.busy.items())]
    rows = []
    for name, live in runs:
        wait = _core_wait(live)
        rows.append([*_stats_row(name, live.chain[END_TO_END]), "-" if wait is None else f"{wait[0]:.0f}"])
    return [
        *title,
        "The clients' run again while another program keeps one core busy (a Python loop at normal priority, as a "
        "camera's detector or a team's own code would): first at the host's normal scheduling, then with the control "
        f"loop at real-time priority (`[deployment] realtime = {max(res.busy)}`: driver, odometry, localizer, navigator, "
        "motor and the router at SCHED_FIFO, ahead of every normal process for a core). End to end [ms], and how "
        "long a thread of the robot's services waited for a core each time it got one [us].",
        "",
        *table(["run", "n", "p50", "p90", "p99", "max", "waited for a core"], rows),
    ]


def _around_fix(res: Results) -> list[str]:
    """The localizer's stage and end to end of the odom samples that come just after a late fix, beside the others."""
    runs = [(name, live) for name, live in (("clients", res.base), ("peers", res.peer), ("composed", res.composed)) if live is not None]
    rows = []
    for name, live in runs:
        for group in AROUND_FIX:
            if f"{END_TO_END}, {group}" not in live.chain:
                continue
            loc, e2e = (Stats.of(live.chain[f"{s}, {group}"]) for s in SPLIT)
            stage = [fmt(loc.p50), fmt(loc.p90), fmt(loc.max)] if name != "composed" else ["-"] * 3
            rows.append([f"{name}: {group}", str(e2e.n), *stage, fmt(e2e.p50), fmt(e2e.p90), fmt(e2e.max)])
    if not rows:
        return []
    header = ["run: samples", "n", "localizer p50", "p90", "max", "end to end p50", "p90", "max"]
    return [
        "",
        "### The localizer around a late fix",
        "",
        "A fix comes about 0.3 s after its capture, and the localizer re-integrates its history since then (30 "
        "filter steps: 0.6 to 2.5 ms on the hosts measured). It holds a fix while odometry flows and applies it in "
        "the gap after the next odom sample, once that sample's pose is out, so no sample should wait for it. In "
        "each run above, the localizer's stage and end to end of the odom samples that reached the observer within "
        f"{NEAR_FIX * 1e3:g} ms after a fix (those a fix served as it came would hold up), beside the others "
        "(composed, the services' outputs leave the process after the samples they lead to: end to end only). [ms]",
        "",
        *table(header, rows),
    ]


def _composed_latency(res: Results, base: Live) -> list[str]:
    """The same chain with the robot's services composed in one process (stack/composed.py)."""
    comp = res.composed
    if comp is None:
        return []
    e2e, client = Stats.of(comp.chain[END_TO_END]), Stats.of(base.chain[END_TO_END])
    bare = (
        [f"- {ratio_line('end to end (composed)', comp.chain[END_TO_END], res.chains['client'].latency)}"] if "client" in res.chains else []
    )
    return [
        "",
        "### The robot's services composed in one process",
        "",
        f"The same measurement, {', '.join(res.plan.compose)} in one process (`zenav up --compose ...`): they reach "
        f"each other directly in the process and the rest of the stack through one shared client session. The "
        f"observer still hears every topic through the router. A topic leaves the process after the samples it "
        f"leads to are served there (each service's output goes to the others in the process first, then to "
        f"Zenoh), so the observer hears the wheel command before the odom sample it came from: the four services' "
        f"stages are one, from the encoder sample's arrival to the wheel command's. {comp.wall:.0f} s window, "
        f"machine {comp.machine_busy:.0%} busy. [ms]",
        "",
        *table(["stage", "n", "p50", "p90", "p99", "max"], _composed_rows(comp.chain)),
        "",
        f"End to end p50 {fmt(e2e.p50)} ms and p99 {fmt(e2e.p99)} ms composed, {fmt(client.p50)} / {fmt(client.p99)} ms "
        f"as separate processes.",
        *bare,
    ]


def ratios(stack: Sequence[float], bare: Sequence[float]) -> tuple[float, float]:
    """End to end over the bare chain: (p50, p99) of `stack` [ms] over those of `bare` [ms]."""
    a, b = Stats.of(stack), Stats.of(bare)
    return a.p50 / b.p50, a.p99 / b.p99


def ratio_line(name: str, stack: Sequence[float], bare: Sequence[float]) -> str:
    """`name / bare chain: p50 1.21x, p99 1.40x`."""
    p50, p99 = ratios(stack, bare)
    return f"{name} / bare chain: p50 {fmt(p50)}x, p99 {fmt(p99)}x"


def _floor(res: Results) -> list[str]:
    """The stack's chain beside the bare five-hop chain (bench/chain.py), stage by stage, per Zenoh mode measured."""
    runs = {mode: live for mode, live in (("client", res.base), ("peer", res.peer)) if live is not None and mode in res.chains}
    if not res.chains:
        return []
    stages = (*STAGES, END_TO_END)
    header, rows = ["stage"], [[f"**{s}**" if s == END_TO_END else s] for s in stages]
    for mode, live in runs.items():
        header += [f"{mode}s p50: stack / bare", f"{mode}s p99: stack / bare"]
        for row, stage in zip(rows, stages):
            a, b = Stats.of(live.chain[stage]), Stats.of(res.chains[mode].stages[stage])
            row += [f"{fmt(a.p50)} / {fmt(b.p50)}", f"{fmt(a.p99)} / {fmt(b.p99)}"]
    notes = [ratio_line(f"end to end ({m}s)", live.chain[END_TO_END], res.chains[m].latency) for m, live in runs.items()]
    notes += [f"one relay process (decode, publish) at {RATE:g} Hz, {m}s: {fmt(c.relay_cores, 3)} of a core" for m, c in res.chains.items()]
    notes += [line for m, live in runs.items() if (line := _waits_line(m, live, res.chains[m]))]
    return [
        "",
        "### The floor: a bare chain of the same five hops",
        "",
        "A publisher paced like the sim, four relay processes that only decode and publish again, and the same "
        "observer process (bench/chain.py): the five hops of the chain with the same codec, publisher settings, "
        "Zenoh mode and measuring, no service work, on the stack's router over the same window of each latency run, "
        "under a robot id of its own. Each stage is one hop and a relay's work in the bare chain, one hop and a "
        "service's in the stack. Their ratio is not a goal: whatever speeds Zenoh up speeds both; what the "
        "services add is measured above, against the relay arm. [ms]",
        "",
        *table(["chain", "n", "p50", "p90", "p99", "max"], [_stats_row(f"bare chain, {m}s", c.latency) for m, c in res.chains.items()]),
        "",
        *table(header, rows),
        "",
        *[f"- {line}" for line in notes],
    ]


def _core_wait(live: Live) -> tuple[float, float] | None:
    """([us] a thread of r1's robot services waited for a core each time it got one, [1/s] times a service's threads
    got one), or None without schedstat."""
    waits = [w for (robot, name), w in live.waits.items() if robot == live.robots[0] and name in ROBOT_SERVICES]
    runs = sum(n for _, n in waits)
    if runs <= 0:
        return None
    return sum(w for w, _ in waits) / runs * 1e6, runs / len(waits) / live.wall


def _waits_line(mode: str, live: Live, bare: Chain) -> str | None:
    """How long the threads of the robot's services waited for a core each time they got one, beside a relay's."""
    wait = _core_wait(live)
    if wait is None or bare.relay_runs <= 0:
        return None  # no schedstat on this kernel
    return (
        f"waiting for a core, {mode}s (/proc/<pid>/task/*/schedstat): a thread of the robot's services "
        f"{wait[0]:.0f} us each time it got one, {wait[1]:.0f} times a second a "
        f"service; a bare relay's {bare.relay_wait * 1e6:.0f} us, {bare.relay_runs:.0f} times a second"
    )


def _peer_latency(res: Results, base: Live) -> list[str]:
    """The same chain with the services as Zenoh peers (`--zenoh-mode peer`), beside the clients' run."""
    peer = res.peer
    if peer is None:
        return []
    rows = _chain_rows(peer.chain)
    e2e, client = Stats.of(peer.chain[END_TO_END]), Stats.of(base.chain[END_TO_END])
    return [
        "",
        "### Services as Zenoh peers",
        "",
        f"The same measurement, the services started with `--zenoh-mode peer`: they still connect to the router (the "
        f"CLI reaches them through it) and also link to each other directly over loopback; the observer is a peer "
        f"too, as the bare chain's is. "
        f"{peer.wall:.0f} s window, machine {peer.machine_busy:.0%} busy. [ms]",
        "",
        *table(["stage", "n", "p50", "p90", "p99", "max"], rows),
        "",
        f"End to end p50 {fmt(e2e.p50)} ms and p99 {fmt(e2e.p99)} ms as peers, {fmt(client.p50)} / {fmt(client.p99)} ms "
        f"as clients of the router.",
    ]


# ------------------------------------------------------------------ cost
def _load_row(first: str, ld: Load) -> list[str]:
    return [
        first,
        fmt(ld.cpu_per_robot, 3),
        fmt(ld.stack_cores),
        pct(ld.machine_busy),
        fmt(ld.speed, 3),
        str(ld.overruns),
        str(ld.dropped),
        fmt(ld.msgs_per_s, 0),
        fmt(ld.rss_mb, 0),
        f"{fmt(ld.latency.p50)} / {fmt(ld.latency.p99)}",
        str(ld.goal_failures),
        "yes" if ld.keeps_up else f"**no**: {ld.why}",
    ]


LOAD_HEADER = [
    "CPU s per sim s per robot",
    "stack cores",
    "machine busy",
    "sim speed",
    "overruns",
    "dropped",
    "msgs/s",
    "RSS total [MiB]",
    "r1 end to end p50 / p99 [ms]",
    "goals failed",
    "keeps up",
]


def _sum_row(name: str, costs: Sequence[ServiceCost]) -> list[str]:
    cpu = sum(c.cpu_per_sim_s for c in costs)
    return [name, fmt(cpu, 3), f"{cpu:.1%}", f"{sum(c.rss_mb for c in costs):.0f}", "", ""]


def cost(res: Results) -> list[str]:
    """The cost section (none without the one-robot run)."""
    base = res.plain or res.base
    if base is None:
        return []
    rows, total = [], 0.0
    costs = services(base)
    for c in costs:
        total += c.cpu_per_sim_s
        rows.append([c.name, fmt(c.cpu_per_sim_s, 3), f"{c.cpu_per_sim_s:.1%}", f"{c.rss_mb:.0f}", fmt(c.msgs_in, 0), fmt(c.msgs_out, 0)])
    rss = sum(c.rss_mb for c in costs)
    rows.append(["**whole stack**", f"**{fmt(total, 3)}**", f"{total:.1%}", f"{rss:.0f}", "", ""])
    robot = [c for c in costs if c.name in ROBOT_SERVICES]
    rows.append(_sum_row(f"robot's services ({', '.join(ROBOT_SERVICES)})", robot))
    if res.composed is not None:
        comp = services(res.composed)
        rows += [_sum_row("robot's services composed in one process", [c]) for c in comp if c.name == "composed"]
        rows.append(_sum_row("whole stack, robot's services composed", comp))
    if res.peer is not None:
        peers = services(res.peer)
        cpu = sum(c.cpu_per_sim_s for c in peers)
        rows.append(["whole stack, services as peers", fmt(cpu, 3), f"{cpu:.1%}", f"{sum(c.rss_mb for c in peers):.0f}", "", ""])
        router = next((c for c in peers if c.name == "router"), None)
        if router is not None:
            rows.append(
                ["router, services as peers", fmt(router.cpu_per_sim_s, 3), f"{router.cpu_per_sim_s:.1%}", f"{router.rss_mb:.0f}", "", ""]
            )
    lines = [
        "## Cost",
        "",
        "One robot at 100 Hz, realtime, the stack alone on its router: CPU time (utime + stime from /proc) per "
        "simulated second, per process, "
        f"resident memory at the end, messages per simulated second from the services' diag counters. This bench "
        f"process (driving the robot, following its diag) used {fmt(base.bench_cpu / base.wall, 3)} of a core beside "
        f"it, the latency observer (a process of its own) not counted. The rows of the peers and of the composed "
        "deployment come from their latency runs, whose router also carried the relay arm and the bare chain.",
        "",
        *table(["process", "CPU s per sim s", "of one core", "RSS [MiB]", "msgs in/s", "msgs out/s"], rows),
    ]
    if res.rates:
        lines += ["", f"### Sensor rate (one robot, realtime, {res.plan.sweep_window:g} s windows)", ""]
        lines += table(["rate [Hz]", *LOAD_HEADER], [_load_row(f"{ld.rate:g}", ld) for ld in res.rates])
    if res.robots:
        lines += ["", f"### Robots on one router (100 Hz, realtime, {res.plan.sweep_window:g} s windows)", ""]
        lines += table(["robots", *LOAD_HEADER], [_load_row(str(ld.robots), ld) for ld in res.robots])
        lines += ["", _robots_verdict(res.robots)]
    lines += [
        "",
        "`sim speed`: stack time advanced over wall time asked (1.0 = kept its clock); `overruns`: times a sim fell "
        "more than its max_burst steps behind and dropped time; `dropped`: inputs dropped by the services (queue "
        "full or stale); `stack cores`: CPU of every stack process and the router over the wall window.",
    ]
    if res.boards:
        lines += ["", *boards(res)]
    return lines


def boards(res: Results) -> list[str]:
    """What the robot computer spends: the robot profile on the emulated board, per deployment."""
    rows = []
    for name, r in res.boards.items():
        each = ", ".join(f"{p} {fmt(c, 3)}" for p, c in r.cores.items() if p != "router")
        failed = "; ".join(r.goal_failures) or "none"
        router, lat = fmt(r.cores.get("router", math.nan), 3), f"{fmt(r.latency.p50)} / {fmt(r.latency.p99)}"
        rows.append([name, f"**{fmt(r.robot, 3)}**", each, router, fmt(r.encoders_hz, 0), lat, failed])
    return [
        f"### The robot computer: the robot profile on the emulated board ({res.plan.board_window:g} s windows)",
        "",
        "A real robot runs the driver where the simulation runs the sim. `zenav up --profile robot`'s services (driver, "
        "motor, odometry, localizer, navigator on the wall clock, as Zenoh peers) on the emulated ROSArduinoBridge "
        f"board (a pseudo-terminal at {BAUD} baud, in the bench's process: its CPU is the board's), while a program "
        f"drives a {board.SQUARE[0][0]:g} m square at {board.SPEED:g} m/s with no VPS. CPU per wall second from /proc; "
        "the encoder samples the odometry took a second, over the window's last (the driver's `sensor_rate`: "
        f"{DriverConfig().sensor_rate:g}); `sample to wheels`: for half a window after it, from the driver's stamp of an "
        "encoder sample to the `motors/wheels` command made from it reaching the bench's process (composed, the "
        "driver has it a hop sooner), the serial link's replies aside. Also `python -m zenav.bench.board --seconds 20`.",
        "",
        *table(
            ["deployment", "cores, router aside", "by process", "router", "encoders/s", "sample to wheels p50 / p99 [ms]", "goals failed"],
            rows,
        ),
    ]


def _robots_verdict(loads: Sequence[Load]) -> str:
    ok = [ld.robots for ld in loads if ld.keeps_up]
    bad = [ld for ld in loads if not ld.keeps_up]
    if not bad:
        return f"Every robot count tried kept up (up to {max(ok)})."
    first = bad[0]
    kept = f"kept up with {max(ok)} robot(s)" if ok else "did not keep up even with one robot"
    return f"One router on this machine {kept}; at {first.robots} it stopped keeping up: {first.why}."


# ------------------------------------------------------------------ speed
def speed(res: Results) -> list[str]:
    rows = [
        [
            r.harness,
            f"{r.rtf:g}",
            str(r.goals),
            str(r.failed),
            str(r.overruns),
            *(fmt(r.means[k]) for k in METRICS),
            ", ".join(r.differs) or "-",
            "yes" if r.within_noise else "**no**",
            f"{r.wall:.0f}",
        ]
        for r in res.speed
    ]
    best = highest_by_harness(res.speed)
    used = "." if res.rtf <= best.get("processes", res.rtf) else ", above it (a fixed factor in this plan): read them so."
    return [
        "## Speed of simulation",
        "",
        f"The whole stack at each realtime factor, seeds {list(res.plan.speed_seeds)}: seed 002's path, then "
        "turn_to_heading to each heading of the turn sweep (turns at 2 rad/s show a late command first); as separate "
        "processes (as `zenav up` runs it, and the accuracy runs below) and in one process (as the integration tests "
        "run it). Within noise: every goal succeeded, no sim overrun, and each mean differs from realtime's by less "
        "than twice the standard error of the difference (samples per goal).",
        "",
        *table(["harness", "rtf", "goals", "failed", "overruns", *METRICS, "differs from realtime", "within noise", "wall [s]"], rows),
        *_failures((f"{r.harness}, rtf {r.rtf:g}", r) for r in res.speed),
        "",
        "Highest realtime factor within noise of realtime: "
        + ", ".join(f"{h} **{v:g}**" for h, v in best.items())
        + f". The accuracy and navigation runs below ran as processes at {res.rtf:g}{used}",
    ]


# ------------------------------------------------------------------ accuracy
def _cm(x: float) -> str:
    return fmt(x * 100)


def accuracy(res: Results) -> list[str]:
    lines = ["## Localization accuracy", ""]
    if res.modes:
        first = next(iter(res.modes.values()))
        lines += [
            f"Each fusion mode live in the stack ({first.spec.harness}), closed loop (the navigator drives on its pose): "
            "default scenario, "
            f"seed {first.spec.seed}, {first.spec.laps:g} lap(s) of the 1 m square, rtf {first.rtf:g}. Errors after "
            "a 2 s warm-up, against the truth at each pose's t. [cm, deg]",
            "",
        ]
        rows = []
        for mode, s in res.modes.items():
            corner = summary(s.errors["point"])
            rows.append(
                [
                    mode,
                    _cm(s.pose.rmse),
                    _cm(s.pose.max),
                    _cm(s.pose.final),
                    fmt(math.degrees(s.pose.heading_rmse)),
                    _cm(s.odom.rmse),
                    f"{_cm(corner[0])} / {_cm(corner[2])}",
                    str(len(s.failures)),
                    f"[plot](run_{mode}.png)",
                ]
            )
        lines += table(
            ["mode", "RMSE", "max", "final", "heading RMSE", "odom RMSE", "corner error mean / max", "goals failed", "trajectory"], rows
        )
        lines += _failures(res.modes.items())
    for scenario in dict.fromkeys(sc for sc, _ in res.scenarios):
        runs = [s for (sc, _), s in res.scenarios.items() if sc == scenario]
        lines += ["", f"### {scenario}", "", _replay_intro(scenario, runs), ""]
        live = [(s.pose.rmse, s.pose.max, s.pose.final, s.pose.heading_rmse, None) for s in runs]
        rows = [_score_row("**live** (configured mode)", live)]
        for mode in runs[0].replay:
            sc = [s.replay[mode] for s in runs]
            rows.append(
                _score_row(
                    mode,
                    [(x.rmse, x.max, x.final, x.heading_rmse, x.outage_end) for x in sc],
                    sum(x.fixes_accepted or 0 for x in sc),
                    sum(x.fixes_rejected or 0 for x in sc),
                )
            )
        lines += table(
            ["mode", "RMSE mean (sd)", "max", "final mean", "heading RMSE [deg]", "error at outage end", "fixes accepted / rejected"], rows
        )
        if f"run_{scenario}.png" in res.plots:
            lines += ["", f"![{scenario}](run_{scenario}.png)"]
    if res.modes:
        lines += [""] + [f"![{mode}](run_{mode}.png)" for mode in res.modes]
    return lines


def _replay_intro(scenario: str, runs: Sequence[Summary]) -> str:
    return (
        f"Seeds {[s.spec.seed for s in runs]}, {runs[0].spec.laps:g} lap(s) of the square each, {runs[0].spec.harness}, "
        f"rtf {runs[0].rtf:g}. The "
        "live row is the configured mode in the stack; every mode below is fed offline with the same run's odometry, "
        "fixes (at the times the localizer received them) and sensors (the localizer study), so the "
        "rules are compared on the same data. RMSE mean over seeds (sd), max over seeds. [cm]"
    )


def _score_row(name: str, scores: Sequence[tuple], accepted: int | None = None, rejected: int | None = None) -> list[str]:
    rmse = [s[0] for s in scores]
    outage = [s[4] for s in scores if s[4] is not None]
    return [
        name,
        f"{_cm(statistics.fmean(rmse))} ({_cm(statistics.stdev(rmse) if len(rmse) > 1 else 0.0)})",
        _cm(max(s[1] for s in scores)),
        _cm(statistics.fmean(s[2] for s in scores)),
        fmt(math.degrees(statistics.fmean(s[3] for s in scores))),
        _cm(statistics.fmean(outage)) if outage else "-",
        "-" if accepted is None else f"{accepted} / {rejected}",
    ]


# ------------------------------------------------------------------ navigation
def _spread(values: Sequence[float], digits: int = 2) -> str:
    m, sd, mx = summary(values)
    return f"{fmt(m, digits)} / {fmt(sd, digits)} / {fmt(mx, digits)}"


def navigation(res: Results) -> list[str]:
    rtf = next(iter(res.paths.values()))[0].rtf
    rows = []
    for ctrl, runs in res.paths.items():
        errs = [e * 100 for s in runs for e in s.errors["path"]]
        times = [d for s in runs for d in s.durations["path"]]
        failed = sum(not s.errors["path"] for s in runs)
        rows.append([ctrl, "stack", str(len(runs)), _spread(errs), _spread(times, 1), str(failed)])
        kin = res.kinematic.get(ctrl, [])
        if kin:
            errs = [100 * math.dist((o.x, o.y), PATH[-1]) for o in kin]
            failed = sum(o.result != "succeeded" for o in kin)
            rows.append([ctrl, "kinematic", str(len(kin)), _spread(errs), _spread([o.duration for o in kin], 1), str(failed)])
    lines = [
        "## Navigation",
        "",
        f"Seed 002's path trial: from (0, 0, 0) follow (1, 0) -> (1, 1), default scenario, tolerance as configured; "
        f"final truth error to (1, 1). `stack`: the whole stack at rtf {rtf:g}, seeds {list(res.plan.path_seeds)}; "
        "`kinematic`: the navigator's goal machine on a kinematic robot with the scenario's motors and wheels, "
        f"true pose (the navigator study). The seed's real robot: {SEED_002_ROBOT}.",
        "",
        *table(["controller", "loop", "runs", "error mean / sd / max [cm]", "time mean / sd / max [s]", "failed"], rows),
        *_failures((f"{ctrl} seed {s.spec.seed}", s) for ctrl, runs in res.paths.items() for s in runs),
    ]
    if res.squares:
        rows = [
            [ctrl, _spread([e * 100 for e in s.errors["point"]]), fmt(sum(s.durations["point"]), 1), _cm(s.pose.rmse), str(len(s.failures))]
            for ctrl, s in res.squares.items()
        ]
        laps = next(iter(res.squares.values())).spec.laps
        lines += ["", f"Seed 003's square: move_to_point around the 1 m square, {laps:g} laps, stack at rtf {rtf:g}.", ""]
        header = ["controller", "corner error mean / sd / max [cm]", "total time [s]", "pose RMSE [cm]", "goals failed"]
        lines += table(header, rows)
        lines += _failures(res.squares.items())
    lines += ["", *_turns(res)]
    return lines


def _turns(res: Results) -> list[str]:
    runs = [s for runs in res.paths.values() for s in runs]
    errs = [math.degrees(e) for s in runs for e in s.errors["turn"]]
    failed = sum(len(HEADINGS) - len(s.errors["turn"]) for s in runs)
    m, sd, mx = summary(errs)
    return [
        f"Turns: after each path trial, turn_to_heading to {', '.join(f'{h:g}' for h in HEADINGS)} deg in turn; true "
        f"heading error at each success over {len(errs)} turns: mean {fmt(m)}, sd {fmt(sd)}, max {fmt(mx)} deg; "
        f"{failed} turn(s) did not succeed.",
    ]


# ------------------------------------------------------------------ settle
def settle(res: Results) -> list[str]:
    """How every kind of move ends, against the truth, with each pose error (bench/settle.py)."""
    lines = [
        "## Settle table",
        "",
        "The navigator's goal machine on the world model's robot (the navigator study's harness), each move from "
        "(0, 0, 0) at the default tolerances, fed the truth plus a pose error that jumps at the VPS rate. Errors are "
        "the true final pose to the goal; the arrival swing is the largest true heading change over the last 5 cm "
        "travelled (for a pose, its final turn in place included).",
    ]
    for name, text in res.settle.items():
        lines += ["", f"### With {name}", "", text]
    return lines


# ------------------------------------------------------------------ camera
def camera(res: Results) -> list[str]:
    """The overhead camera: its frames timed and read, then the whole stack with it against the synthetic VPS."""
    lines = ["## Overhead camera", ""]
    if res.cameras:
        lines += [
            "Frames rendered by the sim's camera model from known poses, read by the vps's pipeline (decode, "
            "pupil-apriltags, undistort, the plane homography of a calibration fitted to the fixed tags).",
            "",
            *camera_bench.lines(res.cameras, res.plan.camera_frames),
        ]
    if res.window is not None:
        lines += [
            "",
            "A 1280x720 camera (the default's view, python -m zenav.bench.window), two robots moving, 10 Hz: the vps "
            "looks for each robot's tag in a window round its predicted place, the whole frame every "
            f"{FULL_PERIOD:g} s (after the frame's fixes are out) and at once when a tag is not in its window; beside it, "
            "a reader that searches every frame whole, on the same frames. Frames/s per core: one over the CPU a frame "
            "takes; frame to fix: wall time from the frame's message to its fixes. Goals: >= 120 frames/s per core, "
            "frame to fix p95 < 10 ms, no fix lost.",
            "",
            f"- {res.window.line()}",
        ]
    if res.camera_runs:
        rtf, cam = next(iter(res.camera_runs.values()))[0][1].rtf, Camera()  # the runs' [camera] is the default
        lines += [
            "",
            f"The whole stack, one process per service, rtf {rtf:g}: each trial with the synthetic VPS (the truth plus the "
            f"scenario's VPS errors: the reference scenarios' VPS) and with the camera VPS (the sim renders {cam.rate_hz:g} "
            f"frames a second, the vps detects the robot's tag, {cam.link_delay:g} s link delay; the scenario's odometry "
            "errors and faults either way). Goal error: the truth at each goal's end to its point (square corners, the "
            "path's end). [cm, deg]",
            "",
        ]
        rows = []
        for trial, pairs in res.camera_runs.items():
            for k, source in enumerate(("synthetic", "camera")):
                runs = [p[k] for p in pairs]
                goals = [e for s in runs for e in s.errors["path" if s.spec.trial == "path" else "point"]]
                rmse = [s.pose.rmse for s in runs]
                rows.append(
                    [
                        trial,
                        source,
                        str(len(runs)),
                        f"{_cm(statistics.fmean(rmse))} / {_cm(max(rmse))}",
                        fmt(math.degrees(statistics.fmean(s.pose.heading_rmse for s in runs))),
                        _spread([e * 100 for e in goals]),
                        str(sum(len(s.failures) for s in runs)),
                    ]
                )
        header = ["trial", "VPS", "runs", "pose RMSE mean / max", "heading RMSE", "goal error mean / sd / max", "goals failed"]
        lines += table(header, rows)
        labelled = [(f"{trial} {s.spec.vps} seed {s.spec.seed}", s) for trial, pairs in res.camera_runs.items() for p in pairs for s in p]
        lines += _failures(labelled)
    return lines


# ------------------------------------------------------------------ profile
def profile(res: Results) -> list[str]:
    """CPU per service and sensor period on the in-process bus, back to back and paced, and where it goes."""
    paced = res.costs_paced
    rows = [
        [
            c.name,
            str(c.inputs),
            str(c.outputs),
            fmt(c.per_input, 1),
            fmt(c.per_step, 1),
            fmt(paced[c.name].per_step, 1) if c.name in paced else "-",
            fmt(c.cores(RATE), 4),
        ]
        for c in res.costs.values()
    ]
    robot = sum(res.costs[n].cores(RATE) for n in ROBOT_SERVICES)
    header = ["service", "inputs", "outputs", "us per input", "us per period", "us per period, paced", f"cores at {RATE:g} Hz"]
    out = [
        "## Profile",
        "",
        f"Every service of one robot on one in-process bus (no network), stepped at {RATE:g} Hz by a manual clock "
        f"while the navigator drives squares, {res.plan.profile_seconds:g} s of stack time; CPU is each service's "
        "thread time (decode, handler, encode, dispatch). The network's own cost is not in these figures: it is in "
        "the cost section's per-process CPU. `paced`: the same run with the loop sleeping out each sensor period, as "
        "a service in a process of its own idles between its inputs: what a period costs deployed, code and data "
        "fetched again after the idle time.",
        "",
        *table(header, rows),
        "",
        f"The robot's services ({', '.join(ROBOT_SERVICES)}): {robot:.3f} of a core together.",
    ]
    if paced:
        chain = [n for n in ROBOT_SERVICES if n in paced]
        warm, idle = sum(res.costs[n].per_step for n in chain), sum(paced[n].per_step for n in chain)
        relay_warm, relay_idle = (len(chain) * r for r in res.relays)
        out += [
            "",
            f"A bare chain's relay (decode a message, encode it again): {res.relays[0]:.1f} us per message back to back, "
            f"{res.relays[1]:.1f} us paced. Per period the robot's services take {warm:.0f} us back to back and {idle:.0f} us "
            f"paced, {len(chain)} relays {relay_warm:.0f} and {relay_idle:.0f} us: the services' own work, every input of "
            f"theirs counted (not only the chain's), is {(warm - relay_warm) / 1e3:.2f} ms a period more than the relays' back "
            f"to back and {(idle - relay_idle) / 1e3:.2f} ms paced.",
        ]
    out += _inputs(res)
    for name, hot in res.hot.items():
        out += ["", f"{name}: costliest functions by own time under cProfile (us per period, own / with callees):", ""]
        out += table(["own", "total", "calls", "function"], [[fmt(h.own, 1), fmt(h.total, 1), str(h.calls), f"`{h.where}`"] for h in hot])
    return out + _deployed(res.spied)


def _deployed(d: Deployed | str | None, top: int = 10) -> list[str]:
    """The robot's service processes as deployed, sampled by py-spy: their threads' time in Python, and where it went."""
    if d is None:
        return []
    if isinstance(d, str):
        return ["", "### As deployed", "", f"Not sampled: {d}."]
    rows = [
        [name, fmt(d.cores[name], 3), fmt(d.active(s.samples), 3), ", ".join(f"{t} {d.active(n):.3f}" for t, n in s.threads.most_common())]
        for name, s in d.spied.items()
    ]
    out = [
        "",
        "### As deployed",
        "",
        f"One robot's stack as separate processes at {RATE:g} Hz, clients of one router (as in the latency section), each of "
        f"the robot's service processes sampled by py-spy from outside, without stopping it, {d.rate} times a second for "
        f"{d.sampled} s (bench/spy.py). "
        "A sample is a thread found active (on a core, or ready and waiting for one) with Python on its stack. `CPU`: the "
        "process's over the window (/proc); `Python`: its threads' time active in Python, by thread (Zenoh's readers `rx-*` "
        "serve a sample on the thread that brought it; `MainThread` is the service's worker, and `Condition.wait` below "
        "it waking). What no sample sees is Zenoh's own work in Rust (sockets, routing, waking threads). [cores]",
        "",
        *table(["service", "CPU", "Python", "Python by thread"], rows),
    ]
    for name, s in d.spied.items():
        out += ["", f"{name} as deployed: costliest functions by own samples (us active per period, own / with callees):", ""]
        rows = [[fmt(d.per_period(n), 1), fmt(d.per_period(s.total[f]), 1), f"`{f}`"] for f, n in s.own.most_common(top)]
        out += table(["own", "total", "function"], rows)
    return out


def _inputs(res: Results) -> list[str]:
    """Each input topic of the robot's services: CPU per message, back to back and paced; one chain sample's sum."""
    paced = res.costs_paced
    rows, warm, idle = [], 0.0, 0.0
    for name, topic in zip(ROBOT_SERVICES, CHAIN):  # each robot service's chain input is the chain's message before it
        cost = res.costs.get(name)
        if cost is None:
            continue
        for t in sorted(cost.topics, key=lambda t: (t != topic, t)):
            b2b, slow = cost.per_message(t), paced[name].per_message(t) if name in paced else math.nan
            if t == topic:
                warm, idle = warm + b2b, idle + slow
            rows.append([name, f"**{t}**" if t == topic else t, str(cost.topics[t][0]), fmt(b2b, 1), fmt(slow, 1)])
    if not rows:
        return []
    relays = len(ROBOT_SERVICES) * res.relays[0], len(ROBOT_SERVICES) * res.relays[1]
    return [
        "",
        "Each input of the robot's services, CPU per message: decode, handler and publishing what it returns (bold: "
        "the chain's sample, as the latency section follows it). [us]",
        "",
        *table(["service", "input", "messages", "back to back", "paced"], rows),
        "",
        f"One sample of the chain costs the robot's services {warm:.0f} us back to back and {idle:.0f} us paced, "
        f"{len(ROBOT_SERVICES)} relays {relays[0]:.0f} and {relays[1]:.0f} us.",
    ]


# ------------------------------------------------------------------ fleet
def fleet(res: Results) -> list[str]:
    """The router under N robots' traffic, and the fleet over several hosts."""
    from zenav.bench.fleet import DOUBLED, doubling

    rows = [
        [str(p.robots), fmt(p.router_cores, 3), fmt(p.per_robot, 4), pct(p.delivered), fmt(p.pace), fmt(p.latency.p50), fmt(p.latency.p99)]
        for p in res.fleet
    ]
    n = doubling(res.fleet)
    verdict = f"Delivery p50 reached {DOUBLED:g}x the one-robot figure at {n} robots." if n else "Delivery p50 never doubled."
    out = [
        "## Fleet",
        "",
        f"The router alone (its own process) under N robots' traffic: every contract topic at its rate, fanned out to "
        f"the sessions of the services that read it, each sim's body to every robot's sim (N squared deliveries; "
        f"bench/fleet.py), {res.plan.fleet_window:g} s per N. Latency: every robot's encoder samples (stamped at "
        "sending) at the first sink session. The player and the sink share the machine with the router; "
        "a player pace under 1 means the load generator, not the router, fell behind.",
        "",
        *table(["robots", "router cores", "per robot", "delivered", "player pace", "p50 [ms]", "p99 [ms]"], rows),
        "",
        verdict,
    ]
    h = res.hosts
    if isinstance(h, str):
        out += ["", f"Fleet over several hosts: not run ({h})."]
    elif h is not None:
        out += [
            "",
            f"Fleet over {res.plan.fleet_hosts} hosts (network namespaces on a bridge, one router each, linked): every "
            f"robot heard on every host: {'yes' if h.heard_all else '**no**'}. Host {h.killed + 1}'s router killed: the "
            f"others' longest silence of each other's robots {fmt(h.longest_gap * 1e3, 0)} ms (limit 500 ms); the killed "
            f"host's robot still heard after it: {'**yes**' if h.lost_heard else 'no'}.",
        ]
    return out
