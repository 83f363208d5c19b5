"""Many robots: the router alone under N robots' traffic, then a fleet over several hosts.

Router load: a player process publishes every topic of N robots at its contract rate
(docs/contract.md: sensors, truth and the chain at 100 Hz, clock and the sim's body at
20 Hz, compass, fixes and vps at 10 Hz, nav/state at 5 Hz, six diags at 1 Hz), each
message a Clock stamped with the wall clock; a sink process holds one session per
subscribing service, each subscribed to what that service reads, so the router fans out
as for real stacks. The bodies go on one field key that every robot's sim reads, so they
take one session per robot and grow as N squared. Per N: the router's CPU and the
delivery latency (sink arrival - stamp).

Hosts: network namespaces joined by veth pairs to a bridge (in a namespace of its own,
addresses in 10.213.7.0/24, which exist only inside them), one router per host linked
to the others, one robot's traffic played per host, and a watcher per host on
`zenav/*/sensors/encoders`. Every watcher must hear every robot; then one host's router is killed
and the others must go on hearing each other without a gap.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import zenoh

from zenav.bench import child
from zenav.bench.latency import Stats
from zenav.common import codec, keys
from zenav.common import messages as m
from zenav.common.bus import ZenohBus, zenoh_config
from zenav.services.sim.service import BODY_RATE_HZ, SimConfig
from zenav.stack.launcher import ProcStack

# (suffix, rate [Hz], sessions that read it: the services subscribed to it, the first the latency probe's)
TRAFFIC = (
    ("clock", SimConfig().clock_rate_hz, 5),
    ("sensors/encoders", 100.0, 1),
    ("sensors/imu", 100.0, 2),
    ("odom", 100.0, 1),
    ("pose", 100.0, 1),
    ("cmd_vel", 100.0, 1),
    ("motors/wheels", 100.0, 2),
    ("sim/truth", 100.0, 1),
    ("sensors/compass", 10.0, 2),
    ("vps/pose", 10.0, 1),
    ("localizer/fixes", 10.0, 0),
    ("nav/state", 5.0, 0),
    ("diag/all", 6.0, 0),  # six services' diag at 1 Hz
)
SESSIONS = 5  # the most services of one robot reading one of its topics (clock: all but the sim)
# (suffix, rate [Hz]) of each robot on the field's key, which every robot's sim reads (its own included)
FIELD_TRAFFIC = (("sim/body", BODY_RATE_HZ),)
PROBE = "sensors/encoders"  # the topic whose delivery latency is measured (100 Hz, read by the first session)
TICK = 0.01  # [s] the player's pace
READY = "ready"
END = keys.key("fleet", "end")  # the player's last message: the sink stops counting
DONE = keys.key("fleet", "done")  # the sink's answer: the player may close its session
FINISH = 30.0  # [s] the player waits this long for the sink's answer
ALL = "all"  # a watcher has heard every robot
START = 60.0  # [s] for the processes in the namespaces to start and hear each other
DOUBLED = 2.0  # delivery p50 this many times the one-robot p50: the router is past its capacity

SUBNET = "10.213.7"  # /24 used only inside the namespaces
PORT = 7447
GAP = 0.5  # [s] the longest silence of a surviving robot that counts as undisturbed


def robot_ids(n: int, prefix: str = "f") -> list[str]:
    return [f"{prefix}{i + 1}" for i in range(n)]


def play(connect: str, robots: list[str], duration: float) -> float:
    """Publish every robot's traffic at its rate for `duration` s, then the end marker; returns the
    pace kept (duration over the wall time it took: under 1, this process could not keep up).

    The session stays open until the sink says it heard the end: closing it discards what its
    queues still hold (a router past its capacity leaves a backlog there), while the end marker,
    sent last, may already be through: the sink would count those samples as lost."""
    bus = ZenohBus.open(connect)
    finished = threading.Event()
    bus.subscribe(DONE, lambda key, data: finished.set())
    plan = [(keys.key(r, s), max(round(1.0 / (rate * TICK)), 1)) for r in robots for s, rate, _ in TRAFFIC]
    plan += [(keys.field_key(s), max(round(1.0 / (rate * TICK)), 1)) for _ in robots for s, rate in FIELD_TRAFFIC]
    start = time.monotonic()
    for k in range(round(duration / TICK)):
        delay = start + k * TICK - time.monotonic()
        if delay > 0:
            time.sleep(delay)  # pacing, as the sim's timer does
        data = codec.encode(m.Clock(t=k * TICK + TICK, wall=time.time()))
        for key, every in plan:
            if k % every == 0:
                bus.publish(key, data)
    pace = duration / max(time.monotonic() - start, 1e-9)
    bus.publish(END, b"")
    heard = finished.wait(FINISH)
    bus.close()
    if not heard:
        raise RuntimeError(f"the fleet sink did not answer the end within {FINISH:g} s")
    return pace


def sink(connect: str, robots: list[str], timeout: float) -> dict[str, Any]:
    """Subscribe as the services would; at the end marker, the probe's count and latencies [ms].

    The probe (every robot's PROBE topic on the first session) is a Python callback; the other
    subscriptions take their samples into a one-slot ring in Zenoh, so the router does all of
    the fan-out while this process stays light. Every robot's sim reads the field's key: one
    session a robot (the first ones shared with the services')."""
    buses = [ZenohBus.open(connect) for _ in range(max(SESSIONS, len(robots)))]
    lock = threading.Lock()
    latency: list[float] = []
    done = threading.Event()
    rings = []

    def probe(key: str, data: bytes) -> None:
        arrival = time.time()
        with lock:
            latency.append((arrival - codec.decode(data, m.Clock).wall) * 1e3)

    for i, bus in enumerate(buses):
        for r in robots:
            for suffix, _, readers in TRAFFIC:
                if i == 0 and suffix == PROBE:
                    bus.subscribe(keys.key(r, suffix), probe)
                elif i < readers:
                    rings.append(bus.session.declare_subscriber(keys.key(r, suffix), zenoh.handlers.RingChannel(1)))
        if i < len(robots):
            for suffix, _ in FIELD_TRAFFIC:
                rings.append(bus.session.declare_subscriber(keys.field_key(suffix), zenoh.handlers.RingChannel(1)))
    buses[0].subscribe(END, lambda key, data: done.set())
    print(READY, flush=True)
    if done.wait(timeout):
        buses[0].publish(DONE, b"")
    for bus in buses:
        bus.close()
    return {"latency": latency}


def expected(robots: int, duration: float) -> int:
    """Probe samples the sink should see from the player's run (every robot's PROBE topic)."""
    rate = next(r for s, r, _ in TRAFFIC if s == PROBE)
    return robots * round(duration * rate)


@dataclass(frozen=True)
class Point:
    """The router under N robots' traffic."""

    robots: int
    router_cores: float  # [cores] router CPU over the run
    delivered: float  # fraction of the probe's samples that arrived
    pace: float  # the player's: under 1, the load generator (not the router) could not keep up
    latency: Stats  # [ms] delivery, every robot

    @property
    def per_robot(self) -> float:
        """[cores] router CPU per robot."""
        return self.router_cores / self.robots


def router_load(counts: tuple[int, ...], duration: float, log_dir: Path) -> list[Point]:
    """One point per robot count, each on a fresh router process."""
    out = []
    for n in counts:
        with ProcStack((), (), log_dir) as stack:
            out.append(_point(stack, n, duration))
    return out


def _point(stack: ProcStack, n: int, duration: float) -> Point:
    ids = robot_ids(n)
    sub = subprocess.Popen(child.argv(sink, stack.endpoint, ids, duration + 30.0), stdout=subprocess.PIPE, text=True)
    assert sub.stdout is not None
    try:
        if sub.stdout.readline().strip() != READY:
            raise RuntimeError("fleet sink did not start")
        c0, t0 = stack.sample()[ProcStack.ROUTER].cpu, time.monotonic()
        player = child.argv(play, stack.endpoint, ids, duration)
        played = subprocess.run(player, check=True, timeout=duration + 60.0, capture_output=True, text=True)
        c1, t1 = stack.sample()[ProcStack.ROUTER].cpu, time.monotonic()
        res = json.loads(sub.communicate(timeout=30.0)[0])
    finally:
        if sub.poll() is None:
            sub.kill()
            sub.wait()
        sub.stdout.close()
    delivered = len(res["latency"]) / max(expected(n, duration), 1)
    return Point(n, (c1 - c0) / (t1 - t0), delivered, float(played.stdout), Stats.of(res["latency"]))


def doubling(points: list[Point]) -> int | None:
    """The fewest robots whose delivery p50 is DOUBLED times the one-robot run's (None: none was)."""
    first = points[0].latency.p50
    return next((p.robots for p in points if p.latency.p50 >= DOUBLED * first), None)


# ------------------------------------------------------------------ several hosts
def _ip(*args: str) -> None:
    subprocess.run(["ip", *args], check=True, capture_output=True)


def netns_available() -> str | None:
    """None if network namespaces can be made here, else why not."""
    if os.geteuid() != 0:
        return "network namespaces need root"
    name = f"zf-probe-{os.getpid()}"
    try:
        _ip("netns", "add", name)
        _ip("netns", "del", name)
    except (OSError, subprocess.CalledProcessError) as e:
        return f"`ip netns add` failed: {getattr(e, 'stderr', b'') or e}"
    return None


class Hosts:
    """n namespaces zf<pid>-h<i> on a bridge in zf<pid>-sw, host i at SUBNET.(10 + i)."""

    def __init__(self, n: int) -> None:
        self.tag = f"zf{os.getpid() % 100000}"
        self.names = [f"{self.tag}-h{i + 1}" for i in range(n)]
        self.switch = f"{self.tag}-sw"

    def address(self, i: int) -> str:
        return f"{SUBNET}.{11 + i}"

    def __enter__(self) -> Hosts:
        _ip("netns", "add", self.switch)
        _ip("-n", self.switch, "link", "add", "br0", "type", "bridge")
        _ip("-n", self.switch, "link", "set", "br0", "up")
        for i, ns in enumerate(self.names):
            _ip("netns", "add", ns)
            _ip("-n", ns, "link", "set", "lo", "up")
            _ip("-n", ns, "link", "add", "eth0", "type", "veth", "peer", "name", f"p{i}", "netns", self.switch)
            _ip("-n", ns, "addr", "add", f"{self.address(i)}/24", "dev", "eth0")
            _ip("-n", ns, "link", "set", "eth0", "up")
            _ip("-n", self.switch, "link", "set", f"p{i}", "master", "br0")
            _ip("-n", self.switch, "link", "set", f"p{i}", "up")
        return self

    def __exit__(self, *exc: object) -> None:
        for ns in [*self.names, self.switch]:  # deleting a namespace deletes its veth ends
            subprocess.run(["ip", "netns", "del", ns], capture_output=True)

    def wait_listening(self, i: int, port: int, timeout: float = 20.0) -> None:
        """Until host i accepts TCP connections on `port` (asked from inside its namespace)."""
        probe = ["ip", "netns", "exec", self.names[i], "bash", "-c", f"echo > /dev/tcp/{self.address(i)}/{port}"]
        deadline = time.monotonic() + timeout
        while subprocess.run(probe, capture_output=True).returncode != 0:
            if time.monotonic() > deadline:
                raise RuntimeError(f"host {i + 1}'s router is not listening after {timeout} s")
            time.sleep(0.1)  # polling a port that is not open yet

    def run(self, i: int, argv: list[str], log: Path) -> subprocess.Popen[bytes]:
        """Start argv in host i's namespace (`ip netns exec` becomes the process: its pid is argv's); stdin a pipe."""
        with open(log, "w") as f:
            return subprocess.Popen(
                ["ip", "netns", "exec", self.names[i], *argv], stdin=subprocess.PIPE, stdout=f, stderr=subprocess.STDOUT
            )


@dataclass(frozen=True)
class HostsResult:
    """What each host's watcher heard."""

    heard_all: bool  # before the kill, every host's watcher heard every robot
    killed: int  # the host whose router was killed
    longest_gap: float  # [s] the longest silence of a surviving robot at a surviving watcher, over the kill
    lost_heard: bool  # a surviving watcher still heard the killed host's robot after the kill


def watch(connect: str, robots: list[str]) -> None:
    """Print READY once subscribed, ALL once every robot was heard, then, when stdin closes, the
    arrival times [s, wall] of every robot's PROBE samples as JSON."""
    bus = ZenohBus.open(connect)
    heard: dict[str, list[float]] = {}
    lock = threading.Lock()
    everyone = threading.Event()

    def on_sample(key: str, data: bytes) -> None:
        with lock:
            heard.setdefault(key.split("/")[1], []).append(time.time())
            if not everyone.is_set() and all(r in heard for r in robots):
                everyone.set()
                print(ALL, flush=True)

    bus.subscribe(f"zenav/*/{PROBE}", on_sample)
    print(READY, flush=True)
    sys.stdin.read()  # the bench closes it to end the watch
    with lock:
        print(json.dumps(heard), flush=True)  # before closing: a session whose router is gone may take long to close
    bus.close()


def _wait_line(path: Path, line: str, timeout: float) -> bool:
    """Until the file has the line (a process in another namespace says where it is)."""
    deadline = time.monotonic() + timeout
    while line not in path.read_text().splitlines():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.1)  # polling a log file another process writes
    return True


def hosts(n: int = 3, phase: float = 3.0, log_dir: Path | None = None) -> HostsResult:
    """Routers on n hosts; a robot and a watcher on each; the last host's router killed once every
    watcher has heard every robot, and `phase` s later the watches end."""
    logs = log_dir or Path(tempfile.mkdtemp(prefix="zenav-fleet-"))
    robots = [f"h{i + 1}" for i in range(n)]
    procs: list[subprocess.Popen[bytes]] = []
    with Hosts(n) as net:
        eps = [f"tcp/{net.address(i)}:{PORT}" for i in range(n)]
        try:
            for i in range(n):  # one after the other, each linking to those already listening
                procs.append(net.run(i, child.argv(router, eps[i], ",".join(eps[:i])), logs / f"router{i}.log"))
                net.wait_listening(i, PORT)
            routers = procs[:]
            watchers = [net.run(i, child.argv(watch, eps[i], robots), logs / f"watch{i}.log") for i in range(n)]
            procs += watchers
            ready = all(_wait_line(logs / f"watch{i}.log", READY, START) for i in range(n))
            procs += [net.run(i, child.argv(play, eps[i], [robots[i]], 3600.0), logs / f"robot{i}.log") for i in range(n)]  # until killed
            heard_all = ready and all(_wait_line(logs / f"watch{i}.log", ALL, START) for i in range(n))
            t_kill = time.time()
            routers[-1].send_signal(signal.SIGKILL)
            time.sleep(phase)  # the survivors go on meanwhile (the measured span)
            for w in watchers[:-1]:
                assert w.stdin is not None
                w.stdin.close()
                w.wait(timeout=30.0)
        finally:
            for p in procs:
                if p.poll() is None:
                    p.kill()
                p.wait()
                if p.stdin is not None:
                    p.stdin.close()
    heard = [json.loads(_last_line(logs / f"watch{i}.log")) for i in range(n - 1)]
    return _judge(heard, robots, t_kill, heard_all)


def _last_line(path: Path) -> str:
    lines = path.read_text().strip().splitlines()
    return lines[-1] if lines else "{}"


def _judge(heard: list[dict[str, list[float]]], robots: list[str], t_kill: float, heard_all: bool) -> HostsResult:
    """From the surviving hosts' watchers (every host but the last)."""
    gaps = [0.0]
    for h in heard:
        for r in robots[:-1]:
            ts = [t for t in h.get(r, []) if t_kill - 1.0 <= t <= t_kill + 2.0]
            gaps.append(float(np.max(np.diff(ts))) if len(ts) > 1 else float("inf"))
    lost = any(t > t_kill + GAP for h in heard for t in h.get(robots[-1], []))
    return HostsResult(heard_all, len(robots) - 1, max(gaps), lost)


def router(listen: str, connect: str) -> None:
    """A router listening on `listen`, linked to the routers at `connect`, until killed."""
    session = zenoh.open(zenoh_config("router", connect=connect or None, listen=listen))
    threading.Event().wait()  # until the bench kills it
    session.close()
