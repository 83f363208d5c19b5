"""One live measurement: robots driving squares on a process stack, watched for a window.

Every robot's stack runs as separate processes on one router (as `zenav up` runs
them), each robot's navigator drives the 1 m square for the whole run. Over the
window: CPU time and memory of every process (/proc), the stack time each sim
advanced, the diag counters, robot r1's sensor-to-wheel chain, and the whole
machine's CPU use (other users included). Nothing else of the bench's runs in the
window: the bare chain it is compared with runs before and after (bench/run.py).
"""

from __future__ import annotations

import os
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import cast

from zenav.bench import chain, trials
from zenav.bench.arm import Arm
from zenav.bench.chain import Chain
from zenav.bench.latency import Observer, configured
from zenav.common import messages as m
from zenav.common.bus import ZenohBus
from zenav.common.client import Client, Latest, ZenavError
from zenav.robot import Robot
from zenav.services import NAMES
from zenav.stack.launcher import ProcStack

SETTLE = 1.0  # [s] wall after the first goals start, before the window opens
START_TIMEOUT = 30.0  # [s] for the first robot's services to come up; each further robot adds START_PER_ROBOT
START_PER_ROBOT = 6.0  # [s]
DIAG_WAIT = 5.0  # [s] wall for the diags that close the window (they come once a second of stack time)
REALTIME = 10  # the control loop's SCHED_FIFO priority in the runs with a busy core (docs/running.md's example)
BUSY_MAX = 600.0  # [s] the longest a busy-core process runs, should the bench not end it
# Another program keeping one core busy: a Python loop at normal priority, bounded in time.
BUSY_LOOP = "import sys, time\nend = time.monotonic() + float(sys.argv[1])\nwhile time.monotonic() < end:\n    pass"


@contextmanager
def busy_core() -> Iterator[None]:
    """One core kept busy by another process for as long as the block runs."""
    proc = subprocess.Popen([sys.executable, "-c", BUSY_LOOP, str(BUSY_MAX)])
    try:
        yield
    finally:
        proc.kill()
        proc.wait()


def realtime_refused(priority: int) -> str | None:
    """Why a process of this host's user may not run at SCHED_FIFO `priority`, or None if it may."""
    probe = f"import os; os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param({priority}))"
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=30.0)
    return None if done.returncode == 0 else (done.stderr.strip().splitlines() or ["refused"])[-1]


def machine_cpu() -> tuple[float, float]:
    """(busy, total) CPU seconds of the whole machine since boot, from /proc/stat."""
    with open("/proc/stat") as f:
        values = [int(v) for v in f.readline().split()[1:]]
    idle = values[3] + values[4]  # idle + iowait
    total = sum(values[:8])  # user .. steal (guest time is already in user)
    return (total - idle) / os.sysconf("SC_CLK_TCK"), total / os.sysconf("SC_CLK_TCK")


@dataclass(frozen=True)
class Live:
    """What one live run measured over its window."""

    robots: tuple[str, ...]
    rate: float  # [Hz] sensor rate
    rtf: float  # realtime factor asked of the sims
    wall: float  # [s] window length
    sim: dict[str, float]  # robot -> stack seconds its sim advanced in the window
    cpu: dict[tuple[str, str], float]  # (robot, service) -> CPU seconds in the window; ("-", "router") too
    rss: dict[tuple[str, str], int]  # [bytes] at the end of the window
    waits: dict[tuple[str, str], tuple[float, int]]  # [s] its threads waited for a core in the window, and the times they got one
    counters: dict[tuple[str, str], dict[str, int]]  # counter increases over the window, from diag
    serve: dict[tuple[str, str], dict[str, float]]  # [us] serving one message of each input in the service's process (diag)
    diag_span: dict[tuple[str, str], float]  # [s] stack time between the two diags the increases are from
    chain: dict[str, list[float]]  # r1's latency per stage and end to end [ms]
    bench_cpu: float  # [s] CPU time of this process (driving the robots; the latency observer is its own) in the window
    machine_busy: float  # fraction of all cores busy in the window (every process on the machine)
    goal_failures: list[str]  # goals aborted or refused, all robots, whole run: why
    arm: dict[str, list[float]] | None = None  # the relay arm's chain over the same window (bench/arm.py), if run
    bare: Chain | None = None  # the bare chain of its hops over the same window (bench/chain.py), if run


def _diags(client: Client) -> dict[str, Latest]:
    return {svc: client.latest(f"diag/{svc}") for svc in NAMES}


def _stack_args(
    robots: int, rate: float, rtf: float, scenario: str, zenoh_mode: str, realtime: int, sets: tuple[str, ...] = ()
) -> list[str]:
    """`zenav up`'s options for the measured stack."""
    args = ["--scenario", scenario, "--set", f"sim.rtf={rtf}", "--set", f"scenario.sensor_rate_hz={rate}", "--zenoh-mode", zenoh_mode]
    args += ["--set", f"deployment.realtime={realtime}", *(a for s in sets for a in ("--set", s))]
    if robots > 1:  # they drive one square from one start: through one another (one robot's body is measured)
        args += ["--set", "sim.body_radius=0"]
    return args


def _stop_driving(stop: threading.Event, bots: Iterable[Robot], drivers: Iterable[threading.Thread]) -> None:
    """End the robots' goals and their drivers."""
    stop.set()
    for b in bots:
        try:
            b.stop()  # ends the running goal at once, and with it the driver
        except ZenavError:
            pass  # a navigator too loaded to answer: its goal ends when the stack stops
    for d in drivers:
        d.join(timeout=10.0)


def run(
    robots: int,
    rate: float,
    rtf: float,
    window: float,
    log_dir: Path,
    scenario: str = "default",
    zenoh_mode: str = "client",
    compose: tuple[str, ...] = (),
    realtime: int = 0,
    during: Callable[[dict[tuple[str, str], int]], object] | None = None,
    beside: bool = False,
    sets: tuple[str, ...] = (),
) -> Live:
    """Start robots r1..rN at `rate` [Hz] and `rtf`, drive them, measure `window` wall seconds.

    zenoh_mode: the services' and the observer's (client: all through the router; peer: also linked directly).
    compose: services of each robot run in one process (stack/composed.py), the rest alone.
    realtime: the control loop's and the router's SCHED_FIFO priority (`[deployment] realtime`; 0: normal).
    during: run in the window instead of waiting it out, given every process's pid by (robot, service), for
    about `window` seconds (bench/spy.py's sampling).
    beside: in the same window on the same router, the relay arm (bench/arm.py) in the same deployment and, with
    the services as separate processes, the bare chain of its hops (bench/chain.py), which then sets the window's length.
    sets: more config settings of the stack ("section.key=value"), e.g. the camera VPS.
    """
    ids = tuple(f"r{i + 1}" for i in range(robots))
    args = _stack_args(robots, rate, rtf, scenario, zenoh_mode, realtime, sets)
    stack = ProcStack(ids, NAMES, log_dir, args, compose=compose, realtime=realtime).start()
    bus = None
    stop = threading.Event()
    control_on = configured()  # the chain the stack runs
    observer = Observer(stack.endpoint, ids[0], control_on, zenoh_mode)  # r1's chain, in the services' mode
    arm = Arm(stack.endpoint, args, log_dir / "relay-arm-sim.log", control_on, zenoh_mode, composed=bool(compose)) if beside else None
    bare: Chain | None = None
    try:
        bus = ZenohBus.open(stack.endpoint)
        bots = {r: Robot(r, bus=bus, lease=False) for r in ids}  # sharing one session: the bus closes it
        diags = {r: _diags(b.client) for r, b in bots.items()}
        clocks = {r: b.client.latest("clock") for r, b in bots.items()}
        deadline = time.monotonic() + START_TIMEOUT + START_PER_ROBOT * (robots - 1)
        for b in bots.values():
            stack.check()
            trials.wait_ready(b, rtf, timeout=max(deadline - time.monotonic(), 1.0))
        if arm is not None:
            arm.start()
            Robot(arm.observer.robot, bus=bus, lease=False).client.latest("clock").wait(timeout=START_TIMEOUT)
        goals: dict[str, list[trials.TrialGoal]] = {r: [] for r in ids}
        drivers = [trials.drive(b, goals[r], stop, rtf) for r, b in bots.items()]
        stop.wait(SETTLE)
        stack.check()
        observer.start()
        before = {r: {s: d.wait() for s, d in ds.items()} for r, ds in diags.items()}
        p0, busy0, self0 = stack.sample(), machine_cpu(), os.times()
        w0, sim0 = time.monotonic(), {r: c.msg.t for r, c in clocks.items()}
        if during is not None:
            during(stack.pids())
        elif arm is not None and not compose:
            bare = chain.measure(stack.endpoint, control_on, rate, window, zenoh_mode)  # the window: the chain's samples
        else:
            time.sleep(window)  # the window: the robots drive, the observer stamps
        stages = observer.stages()
        arm_stages = arm.stages() if arm is not None else None
        p1, busy1, self1 = stack.sample(), machine_cpu(), os.times()
        w1, sim1 = time.monotonic(), {r: c.msg.t for r, c in clocks.items()}
        stack.check()
        after = {r: {s: _diag_after(d, sim1[r]) for s, d in ds.items()} for r, ds in diags.items()}
        _stop_driving(stop, bots.values(), drivers)
    finally:
        stop.set()
        observer.close()
        if arm is not None:
            arm.close()
        if bus is not None:
            bus.close()
        stack.stop()
    keys = [(r, s) for r in ids for s in NAMES]
    return Live(
        robots=ids,
        rate=rate,
        rtf=rtf,
        wall=w1 - w0,
        sim={r: sim1[r] - sim0[r] for r in ids},
        cpu={k: p1[k].cpu - p0[k].cpu for k in p1},  # (robot, "composed") for a composed process
        rss={k: p1[k].rss for k in p1},
        waits={k: (p1[k].waited - p0[k].waited, p1[k].runs - p0[k].runs) for k in p1},
        counters={(r, s): _increase(before[r][s], after[r][s]) for r, s in keys},
        serve={(r, s): after[r][s].serve for r, s in keys},  # the diag that closes the window: its last second
        diag_span={(r, s): after[r][s].t - before[r][s].t for r, s in keys},
        chain=stages,
        bench_cpu=(self1.user + self1.system) - (self0.user + self0.system),
        machine_busy=(busy1[0] - busy0[0]) / max(busy1[1] - busy0[1], 1e-9),
        goal_failures=[f"{r}: {f}" for r, gs in goals.items() for f in trials.failed(gs)],
        arm=arm_stages,
        bare=bare,
    )


def _diag_after(latest: Latest, t: float) -> m.Diag:
    """The first diag from stack time t on, or the newest if none comes soon (a stack far behind)."""
    try:
        return cast(m.Diag, latest.wait(lambda msg: msg.t >= t, timeout=DIAG_WAIT))
    except TimeoutError:
        return cast(m.Diag, latest.msg)


def _increase(a: m.Diag, b: m.Diag) -> dict[str, int]:
    return {k: v - a.counters.get(k, 0) for k, v in b.counters.items()}
