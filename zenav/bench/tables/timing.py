"""The latency section: the sensor-to-wheel chain's stages and end to end, against the bare chain, composed and as peers."""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import TYPE_CHECKING

from zenav.bench import added as added_bench
from zenav.bench.chain import Chain
from zenav.bench.latency import AROUND_FIX, END_TO_END, NEAR_FIX, OUTPUT, SPLIT, Stats, present
from zenav.bench.live import Live
from zenav.bench.profile import RATE
from zenav.bench.tables.markdown import fmt, stats_row, table
from zenav.common.roles import ROBOT_SERVICES

if TYPE_CHECKING:
    from zenav.bench.run import Results

TARGET_ADDED = (0.25, 1.0)  # [ms] what the robot services add to end to end at p50, p99 (bench/added.py)


# ------------------------------------------------------------------ latency
def _chain_rows(chain: dict[str, list[float]]) -> list[list[str]]:
    """A row per stage of the sensor-to-wheel chain, then end to end."""
    return [stats_row(s, chain[s]) for s in present(chain)] + [stats_row(f"**{END_TO_END}**", chain[END_TO_END])]


def _composed_rows(chain: dict[str, list[float]]) -> list[list[str]]:
    """The chain's rows composed: delivery, the robot's services as one stage (from the encoder sample's arrival
    to the wheel command's: end to end less delivery, sample by sample), end to end."""
    stages = present(chain)
    delivery, e2e = chain[stages[0]], chain[END_TO_END]
    services = [e - d for e, d in zip(e2e, delivery)]
    name = f"{stages[1]} to {stages[-1]}, in one process"
    return [stats_row(stages[0], delivery), stats_row(name, services), stats_row(f"**{END_TO_END}**", e2e)]


def latency(res: Results) -> list[str]:
    """The latency section (none without the one-robot run)."""
    base = res.base
    if base is None:
        return []
    stages = present(base.chain)
    biggest = max(stages[1:], key=lambda s: Stats.of(base.chain[s]).p50)
    topics = ", ".join(f"`{OUTPUT[s]}`" for s in stages[1:-1])
    return [
        "## Latency",
        "",
        f"One robot, every service its own process, one router, realtime, {base.rate:g} Hz, {base.wall:.0f} s window "
        "while the navigator drives the square. Per encoder sample t: the sim's wall-clock stamp of t, then the wall "
        f"arrival of `sensors/encoders`, {topics} and `motors/wheels` of that t at an observer process (the "
        "navigator's control loop as configured: `[navigator] control_on`). `delivery` is sim to a subscriber (one "
        "hop); each service's row is the hop into it plus its work; they add up to end to end (now - t on "
        "`motors/wheels`). Nothing else of the bench runs in the window. [ms]",
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
        rows.append([*stats_row(name, live.chain[END_TO_END]), "-" if wait is None else f"{wait[0]:.0f}"])
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
            loc, e2e = (Stats.of(live.chain.get(f"{s}, {group}", [])) for s in SPLIT)  # no localizer stage: off the chain
            stage = [fmt(loc.p50), fmt(loc.p90), fmt(loc.max)] if name != "composed" and loc.n else ["-"] * 3
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
        "(composed, the services' outputs leave the process after the samples they lead to, and with the control "
        "loop on odom, the localizer off the chain: end to end only). [ms]",
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
    """The stack's chain beside the bare chain of its hops (bench/chain.py), stage by stage, per Zenoh mode measured."""
    runs = {mode: live for mode, live in (("client", res.base), ("peer", res.peer)) if live is not None and mode in res.chains}
    if not res.chains:
        return []
    stages = (*present(next(iter(res.chains.values())).stages), END_TO_END)
    hops = len(stages) - 1
    words = {3: "three", 4: "four", 5: "five"}
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
        f"### The floor: a bare chain of the same {words[hops]} hops",
        "",
        f"A publisher paced like the sim, {words[hops - 1]} relay processes that only decode and publish again, and the "
        f"same observer process (bench/chain.py): the {words[hops]} hops of the chain with the same codec, publisher settings, "
        "Zenoh mode and measuring, no service work, on the stack's router over the same window of each latency run, "
        "under a robot id of its own. Each stage is one hop and a relay's work in the bare chain, one hop and a "
        "service's in the stack. Their ratio is not a goal: whatever speeds Zenoh up speeds both; what the "
        "services add is measured above, against the relay arm. [ms]",
        "",
        *table(["chain", "n", "p50", "p90", "p99", "max"], [stats_row(f"bare chain, {m}s", c.latency) for m, c in res.chains.items()]),
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
