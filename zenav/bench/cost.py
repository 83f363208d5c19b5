"""What a live run cost: CPU seconds per simulated second, memory and message rates per
process, and whether the stacks kept up with their clocks (and what ran out if not)."""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from zenav.bench.latency import END_TO_END, Stats
from zenav.bench.live import Live
from zenav.services import NAMES
from zenav.stack.launcher import ProcStack

KEEP_UP = 0.97  # least ratio of stack time advanced to the time asked (wall x rtf) that counts as keeping up
CPU_FULL = 0.85  # a fraction of the cores (or of one core for one process) this busy counts as saturated


@dataclass(frozen=True)
class ServiceCost:
    """One process of robot r1 (or the router) over the window."""

    name: str
    cpu_per_sim_s: float  # [CPU s / simulated s]
    rss_mb: float  # [MiB]
    msgs_in: float  # [per simulated s]
    msgs_out: float  # [per simulated s]
    ticks_in: float = 0.0  # [per simulated s] sim clock ticks taken (not in msgs_in)


def services(live: Live) -> list[ServiceCost]:
    """Per service of r1, then the router (shared by every robot)."""
    r1 = live.robots[0]
    out = []
    nan = float("nan")  # the router has no diag, a composed process no diag of its own
    for svc in (*NAMES, "composed"):
        key = (r1, svc)
        if key not in live.cpu:
            continue  # composed: the service's CPU is its process's
        cpu = live.cpu[key] / max(live.sim[r1], 1e-9)
        if key in live.counters:
            c, span = live.counters[key], max(live.diag_span[key], 1e-9)
            rates = (c["msgs_in"] / span, c["msgs_out"] / span, c.get("clock_ticks", 0) / span)
            out.append(ServiceCost(svc, cpu, live.rss[key] / 2**20, *rates))
        else:
            out.append(ServiceCost(svc, cpu, live.rss[key] / 2**20, nan, nan))
    router = ProcStack.ROUTER
    out.append(ServiceCost("router", live.cpu[router] / max(live.sim[r1], 1e-9), live.rss[router] / 2**20, nan, nan))
    return out


@dataclass(frozen=True)
class Load:
    """One point of a sweep: how much the stacks used and whether they kept up."""

    robots: int
    rate: float  # [Hz]
    cpu_per_robot: float  # [CPU s per simulated s] one robot's services, averaged over robots
    stack_cores: float  # [cores] every stack process and the router, over the wall window
    machine_busy: float  # fraction of all cores busy (everything on the machine)
    speed: float  # least ratio over robots of stack time advanced to wall x rtf
    overruns: int  # the sims' catch-up resyncs in the window, all robots
    dropped: int  # inputs the services dropped (queue full or stale), all robots
    msgs_per_s: float  # [per wall s] messages published by every service
    rss_mb: float  # [MiB] all processes
    latency: Stats  # r1 end to end [ms]
    goal_failures: int
    keeps_up: bool
    why: str  # what ran out, when it did not keep up


def transport_floor(costs: list[ServiceCost], relay_cores: float, rate: float) -> float:
    """[cores] what the messages the processes `costs` take (clock ticks too) and send would cost at a bare relay's price
    per message (a relay takes and sends one topic at `rate`, for `relay_cores`): their CPU with no work of their own."""
    return sum(c.msgs_in + c.ticks_in + c.msgs_out for c in costs) * relay_cores / (2.0 * rate)


def load(live: Live) -> Load:
    """Summarise a live run as a sweep point."""
    ncores = os.cpu_count() or 1
    robot_cpu = [sum(c for (rr, _), c in live.cpu.items() if rr == r) / max(live.sim[r], 1e-9) for r in live.robots]
    stack_cores = sum(live.cpu.values()) / live.wall
    speed = min(live.sim[r] / (live.wall * live.rtf) for r in live.robots)
    overruns = sum(live.counters[(r, "sim")].get("overruns", 0) for r in live.robots)
    dropped = sum(c.get("dropped_overflow", 0) + c.get("dropped_stale", 0) for c in live.counters.values())
    msgs = sum(c["msgs_out"] for c in live.counters.values()) / live.wall
    keeps_up = speed >= KEEP_UP and overruns == 0 and not live.goal_failures
    return Load(
        robots=len(live.robots),
        rate=live.rate,
        cpu_per_robot=float(np.mean(robot_cpu)),
        stack_cores=stack_cores,
        machine_busy=live.machine_busy,
        speed=speed,
        overruns=overruns,
        dropped=dropped,
        msgs_per_s=msgs,
        rss_mb=sum(live.rss.values()) / 2**20,
        latency=Stats.of(live.chain[END_TO_END]),
        goal_failures=len(live.goal_failures),
        keeps_up=keeps_up,
        why="" if keeps_up else _why(live, stack_cores, ncores),
    )


def not_started(robots: int, rate: float, why: str) -> Load:
    """A sweep point whose stacks did not come up in time."""
    nan = float("nan")
    return Load(robots, rate, nan, nan, nan, nan, 0, 0, nan, nan, Stats.of([]), 0, False, f"did not come up: {why}")


def _why(live: Live, stack_cores: float, ncores: int) -> str:
    """The resource that ran out, from the CPU figures of the window."""
    busiest, cpu = max(live.cpu.items(), key=lambda kv: kv[1])
    if stack_cores >= CPU_FULL * ncores:
        return f"CPU: the stacks used {stack_cores:.2f} of {ncores} cores"
    if live.machine_busy >= CPU_FULL:
        return f"CPU: the machine was {live.machine_busy:.0%} busy, the stacks using {stack_cores:.2f} of {ncores} cores"
    if cpu / live.wall >= CPU_FULL:
        return f"one process at a full core: {busiest[1]} of {busiest[0]} ({cpu / live.wall:.2f} cores)"
    return f"not CPU ({stack_cores:.2f} of {ncores} cores): delivery and queueing; see the latency"
