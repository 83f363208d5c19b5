"""What each service costs per message: CPU time and a deterministic profile, in one process.

Every service of one robot runs on one in-process bus (stack.composed.LocalBus, no
network), the sim stepped by a manual clock at the sensor rate and the others on the
sim clock as deployed, the navigator driving squares. Each step the services are
drained in the chain's order on this thread, so each one's CPU time (thread time) is
its own: decode, handler, encode and the runtime's dispatch. A second run under
cProfile names the functions the time goes to (cProfile slows each call by a constant:
its figures rank the costs; the first run's are the costs).

The same run again `paced`: the loop sleeps out each sensor period, as a service in a
process of its own does between its inputs. What a sample costs then is what it costs
deployed: the code and data it touches, gone cold over the idle period, are fetched
again. A bare chain's relay (decode a message, encode it again: bench/chain.py) is
timed both ways beside them. Each input message is timed by its topic too (decode,
handler, publishing what it returns): what one sample of the chain costs each service.

`zenav bench profile` reports them.
"""

from __future__ import annotations

import cProfile
import pstats
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field

from zenav import services as registry
from zenav.bench import chain
from zenav.common import codec, keys
from zenav.common import messages as m
from zenav.common.bus import MemoryBus
from zenav.common.clock import ManualClock
from zenav.common.config import Settings
from zenav.common.intake import Input
from zenav.common.roles import ROBOT_SERVICES
from zenav.common.runtime import Service
from zenav.common.scenarios import SQUARE
from zenav.stack.composed import LocalBus

RATE = 100.0  # [Hz] the reference sensor rate
ORDER = ("sim", "odometry", "localizer", "navigator", "motor", "vps")  # the chain first, then the camera
GOAL_AT = 1.5  # [s] of stack time: the follow_path goal is sent (the warm-up must be longer)
LAPS = 1000  # squares in the one follow_path goal (more than any run drives)


@dataclass(frozen=True)
class Cost:
    """One service over a run."""

    name: str
    steps: int  # sensor periods measured
    inputs: int  # messages it took (clock ticks not counted)
    outputs: int  # messages it published
    cpu: float  # [s] thread CPU time: inputs, clock ticks, timers and publishing
    topics: dict[str, tuple[int, float]] = field(default_factory=dict)  # input topic -> (messages, CPU s dispatching them)

    def per_message(self, topic: str) -> float:
        """[us] CPU per message of an input topic (nan: none came)."""
        n, cpu = self.topics.get(topic, (0, 0.0))
        return cpu / n * 1e6 if n else float("nan")

    @property
    def per_step(self) -> float:
        """[us] CPU per sensor period (one encoder sample and what it brings)."""
        return self.cpu / max(self.steps, 1) * 1e6

    @property
    def per_input(self) -> float:
        """[us] CPU per input message."""
        return self.cpu / max(self.inputs, 1) * 1e6

    def cores(self, rate: float) -> float:
        """Fraction of a core at `rate` [Hz]: CPU per second of stack time."""
        return self.per_step * 1e-6 * rate


@dataclass(frozen=True)
class Hot:
    """One function of a service's profile."""

    where: str  # file:line(function)
    calls: int
    own: float  # [us] per sensor period, in the function itself
    total: float  # [us] per sensor period, with what it calls


def _stack(rate: float) -> tuple[LocalBus, ManualClock, dict[str, Service]]:
    settings = Settings.load(None, scenario={"sensor_rate_hz": rate})
    mem, sim_clock = MemoryBus(), ManualClock(0.0)
    bus = LocalBus(mem)
    svcs: dict[str, Service] = {}
    for name in ORDER:
        cls = registry.load(name)
        svcs[name] = cls(settings, bus, sim_clock if name == "sim" else cls.make_clock(settings))
    for name in registry.NAMES:  # the start order, as launchers use
        svcs[name].start()
    return bus, sim_clock, svcs


def _steps(
    seconds: float, rate: float, bus: LocalBus, clock: ManualClock, svcs: dict[str, Service], warmup: float, paced: bool = False
) -> Iterator[bool]:
    """Advance the clock one sensor period at a time; yields whether the step is measured.

    The squares start once the localizer has had time to place the robot (GOAL_AT).
    `paced`: measured steps are one wall period apart (the loop sleeps out the rest)."""
    points: list[tuple[float, ...]] = [(x, y) for _ in range(LAPS) for x, y in SQUARE]
    goal = m.FollowPath(points=points[:10_000])
    first, start = round(warmup * rate), 0.0
    for i in range(round((warmup + seconds) * rate)):
        clock.advance(1.0 / rate)
        if i == round(GOAL_AT * rate):
            assert isinstance(bus.rest, MemoryBus)
            bus.rest.query(keys.key(svcs["navigator"].robot, "nav/follow_path"), codec.encode(goal))
        if paced and i >= first:
            if i == first:
                start = time.monotonic()
            chain.pace(start, i - first, rate)
        yield i >= first


def relay(seconds: float = 10.0, rate: float = RATE, paced: bool = False) -> float:
    """[us] CPU a bare chain's relay spends per message (chain.forward: decode a sample, encode it again),
    over `seconds` of messages at `rate`, paced or back to back."""
    data = codec.encode(chain.sample(1.0))
    n, start, cpu = round(seconds * rate), time.monotonic(), 0.0
    for i in range(n):
        if paced:
            chain.pace(start, i, rate)
        t0 = time.thread_time()
        chain.forward(data)
        cpu += time.thread_time() - t0
    return cpu / n * 1e6


def measure(seconds: float = 10.0, rate: float = RATE, warmup: float = 3.0, paced: bool = False) -> dict[str, Cost]:
    """CPU per service over `seconds` of stack time at `rate` [Hz], after `warmup` seconds (`paced`: one wall
    period between measured steps, as deployed; else back to back)."""
    bus, clock, svcs = _stack(rate)
    cpu = dict.fromkeys(ORDER, 0.0)
    base: dict[str, tuple[int, int]] = {}
    tick = time.thread_time
    topics: dict[str, dict[str, tuple[int, float]]] = {name: {} for name in ORDER}
    for measured in _steps(seconds, rate, bus, clock, svcs, warmup, paced):
        if measured and not base:
            for name, svc in svcs.items():
                _time_inputs(svc, topics[name])
            base = {n: (s.counters.values["msgs_in"], s.counters.values["msgs_out"]) for n, s in svcs.items()}
        for name in ORDER:
            t0 = tick()
            svcs[name].drain()
            if measured:
                cpu[name] += tick() - t0
    _close(bus, svcs)
    steps = round(seconds * rate)
    out = {}
    for name, s in svcs.items():
        v = s.counters.values
        out[name] = Cost(name, steps, v["msgs_in"] - base[name][0], v["msgs_out"] - base[name][1], cpu[name], topics[name])
    return out


def _time_inputs(svc: Service, into: dict[str, tuple[int, float]]) -> None:
    """From now on, add each input message's dispatch (thread CPU time) to `into` by its topic."""
    dispatch = svc._dispatch

    def timed(item: Input) -> None:
        t0 = time.thread_time()
        dispatch(item)
        if item.kind == "msg":
            n, cpu = into.get(item.suffix, (0, 0.0))
            into[item.suffix] = (n + 1, cpu + time.thread_time() - t0)

    svc._dispatch = timed  # type: ignore[method-assign]


def measure_both(seconds: float = 10.0, rate: float = RATE) -> tuple[dict[str, Cost], dict[str, Cost], tuple[float, float]]:
    """The services' costs back to back and paced, and a relay's [us per message] back to back and paced."""
    costs, paced = measure(seconds, rate), measure(seconds, rate, paced=True)
    return costs, paced, (relay(seconds, rate), relay(seconds, rate, paced=True))


def profile(seconds: float = 5.0, rate: float = RATE, warmup: float = 3.0, top: int = 10) -> dict[str, list[Hot]]:
    """Per service, its `top` functions by own time under cProfile [us per sensor period]."""
    bus, clock, svcs = _stack(rate)
    profs = {name: cProfile.Profile() for name in ORDER}
    for measured in _steps(seconds, rate, bus, clock, svcs, warmup):
        for name in ORDER:
            if measured:
                _profiled(profs[name], svcs[name].drain)
            else:
                svcs[name].drain()
    _close(bus, svcs)
    return {name: _hot(profs[name], round(seconds * rate), top) for name in ORDER}


def _profiled(prof: cProfile.Profile, fn: Callable[[], object]) -> None:
    prof.enable()
    try:
        fn()
    finally:
        prof.disable()


def _hot(prof: cProfile.Profile, steps: int, top: int) -> list[Hot]:
    stats = pstats.Stats(prof).stats  # type: ignore[attr-defined]  # {(file, line, fn): (cc, nc, tt, ct, callers)}
    rows = sorted(stats.items(), key=lambda kv: kv[1][2], reverse=True)[:top]
    return [Hot(_where(f), nc, tt / steps * 1e6, ct / steps * 1e6) for f, (_, nc, tt, ct, _) in rows]


def _where(f: tuple[str, int, str]) -> str:
    path, line, fn = f
    if path == "~":
        return fn  # a builtin: "<method 'encode' of ...>"
    short = "/".join(path.split("/")[-2:])
    return f"{short}:{line}({fn})"


def _close(bus: LocalBus, svcs: dict[str, Service]) -> None:
    for s in svcs.values():
        s.close()
    bus.close()


def lines(costs: dict[str, Cost], paced: dict[str, Cost], relays: tuple[float, float], hot: dict[str, list[Hot]], rate: float) -> list[str]:
    """The costs back to back and paced, a relay's, then each service's hottest functions, as text lines."""
    out = [f"{'service':<10} {'inputs':>7} {'outputs':>7} {'us/input':>9} {'us/period':>9} {'paced':>9} {'core at rate':>12}"]
    for c in costs.values():
        idle = paced[c.name].per_step if c.name in paced else float("nan")
        out.append(f"{c.name:<10} {c.inputs:>7} {c.outputs:>7} {c.per_input:>9.1f} {c.per_step:>9.1f} {idle:>9.1f} {c.cores(rate):>12.4f}")
    robot = sum(costs[n].cores(rate) for n in ROBOT_SERVICES if n in costs)
    out.append(f"robot services ({', '.join(ROBOT_SERVICES)}) at {rate:g} Hz: {robot:.4f} of a core")
    out.append(f"a bare chain's relay (decode, encode): {relays[0]:.1f} us per message back to back, {relays[1]:.1f} paced")
    out += ["", f"{'service':<10} {'input':<18} {'messages':>8} {'us/msg':>8} {'paced':>8}"]
    for c in costs.values():
        for topic, (n, _) in c.topics.items():
            idle = paced[c.name].per_message(topic) if c.name in paced else float("nan")
            out.append(f"{c.name:<10} {topic:<18} {n:>8} {c.per_message(topic):>8.1f} {idle:>8.1f}")
    for name, rows in hot.items():
        out.append("")
        out.append(f"{name}: top functions by own time, then with callees, us per sensor period (under cProfile)")
        out += [f"  {h.own:8.2f} {h.total:8.2f} {h.calls:>8}  {h.where}" for h in rows]
    return out
