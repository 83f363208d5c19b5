"""What the stack costs: CPU and memory per service and robot, boards, the simulation's speed, where the time
goes (profile), and the router under a fleet."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

from zenav.bench import board, camfeed
from zenav.bench.cost import Load, ServiceCost, services
from zenav.bench.latency import configured, input_of
from zenav.bench.profile import RATE
from zenav.bench.speed import METRICS, highest_by_harness
from zenav.bench.spy import Deployed
from zenav.bench.tables.markdown import failures, fmt, pct, table
from zenav.common.roles import ROBOT_SERVICES
from zenav.services.driver.protocol import BAUD
from zenav.services.driver.service import DriverConfig

if TYPE_CHECKING:
    from zenav.bench.run import Results


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
    if res.camera_vps is not None:
        cam = services(res.camera_vps)
        rows += [
            [
                f"{c.name}, camera VPS",
                fmt(c.cpu_per_sim_s, 3),
                f"{c.cpu_per_sim_s:.1%}",
                f"{c.rss_mb:.0f}",
                fmt(c.msgs_in, 0),
                fmt(c.msgs_out, 0),
            ]
            for c in cam
            if c.name in ("sim", "vps")
        ]
        rows.append(_sum_row("whole stack, camera VPS", cam))
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
        "deployment come from their latency runs, whose router also carried the relay arm and the bare chain; the "
        f"camera VPS's from a run of its own ({res.plan.sweep_window:g} s): the sim renders the overhead camera's frames and the vps "
        "reads the robot's tag in them instead of the synthetic fixes.",
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
    """What the robot computer spends: the robot profile and the onboard camera's vps on the emulated board, per
    deployment, then its `robot computer: N core` lines against the goals."""
    rows = []
    for name, r in res.boards.items():
        each = ", ".join(f"{p} {fmt(c, 3)}" for p, c in r.cores.items() if p != "router")
        failed = "; ".join(r.goal_failures) or "none"
        router, lat = fmt(r.cores.get("router", math.nan), 3), f"{fmt(r.latency.p50)} / {fmt(r.latency.p99)}"
        fixes = f"{r.fixes[0]} / {r.fixes[1]}"
        rows.append([name, f"**{fmt(r.robot, 3)}**", each, router, fmt(r.encoders_hz, 0), lat, fixes, failed])
    return [
        f"### The robot computer: the robot profile and its camera on the emulated board ({res.plan.board_window:g} s windows)",
        "",
        "A real robot runs the driver where the simulation runs the sim, and the vps of its own camera. `zenav up "
        "--profile robot`'s services (driver, motor, odometry, localizer, navigator on the wall clock, as Zenoh peers) "
        'and a vps with `[vps] source = "onboard"`, on the emulated ROSArduinoBridge board (a pseudo-terminal at '
        f"{BAUD} baud, in the bench's process: its CPU is the board's), while a program drives a {board.SQUARE[0][0]:g} m "
        f"square at {board.SPEED:g} m/s. The camera: {camfeed.RATE:g} frames a second of 640 x 480, raw as `zenav camera "
        "stream --onboard` sends them, rendered with the sim's onboard camera (its realistic errors) where the board's "
        "wheels took the robot, from the bench's process (its CPU is the camera's). CPU per wall second from /proc; "
        "the encoder samples the odometry took a second, over the window's last (the driver's `sensor_rate`: "
        f"{DriverConfig().sensor_rate:g}); `sample to wheels`: for half a window after it, from the driver's stamp of an "
        "encoder sample to the `motors/wheels` command made from it reaching the bench's process (composed, the "
        "driver has it a hop sooner), the serial link's replies aside; `fixes`: the vps's fixes the localizer took and "
        "refused over the same half window.",
        "",
        *table(
            [
                "deployment",
                "cores, router aside",
                "by process",
                "router",
                "encoders/s",
                "sample to wheels p50 / p99 [ms]",
                "fixes taken / refused",
                "goals failed",
            ],
            rows,
        ),
        "",
        *[f"robot computer: {fmt(cores, 3)} core ({name}; goal {goal:g})" for name, cores, goal in board.budget(res.boards)],
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
        f"The whole stack at each realtime factor, seeds {list(res.plan.speed_seeds)}: the path trial, then "
        "turn_to_heading to each heading of the turn sweep (turns at 2 rad/s show a late command first); as separate "
        "processes (as `zenav up` runs it, and the accuracy runs below) and in one process (as the integration tests "
        "run it). Within noise: every goal succeeded, no sim overrun, and each mean differs from realtime's by less "
        "than twice the standard error of the difference (samples per goal).",
        "",
        *table(["harness", "rtf", "goals", "failed", "overruns", *METRICS, "differs from realtime", "within noise", "wall [s]"], rows),
        *failures((f"{r.harness}, rtf {r.rtf:g}", r) for r in res.speed),
        "",
        "Highest realtime factor within noise of realtime: "
        + ", ".join(f"{h} **{v:g}**" for h, v in best.items())
        + f". The accuracy and navigation runs below ran as processes at {res.rtf:g}{used}",
    ]


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
    control_on = configured()
    for name in ROBOT_SERVICES:
        topic = input_of(name, control_on)  # the input the latency section follows
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
