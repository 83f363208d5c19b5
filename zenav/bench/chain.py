"""The floor the sensor-to-wheel chain is compared with: the same hops with no service work.

A publisher paced like the sim (per sample: its wall clock, `sensors/encoders`, and half
a period later `sim/truth` carrying that wall stamp), one relay process per service of the
configured chain that only decodes a message and publishes it again on the chain's next
topic (`odom`, `cmd_vel`, `motors/wheels`; with control on pose `pose` too), and the
stack's own observer process (bench/latency.py), which stamps every topic of the chain as
it does for the stack: four hops, as sim -> odometry -> navigator -> motor -> observer
(five on pose, the localizer's among them), with the same codec,
publisher settings, Zenoh mode and measuring apparatus, under a robot id of its own.
Its stages compare hop for hop with the stack's.

The relays and the publisher are processes of their own (`relay`, `publish`, run by bench/child.py).
"""

from __future__ import annotations

import subprocess
import sys
import time
from dataclasses import dataclass

from zenav.bench import child
from zenav.bench.latency import END_TO_END, Observer, chain
from zenav.common import codec, keys
from zenav.common import messages as m
from zenav.common.app import PEER_LISTEN
from zenav.common.bus import ZenohBus
from zenav.stack.launcher import read_proc

ROBOT = "chain"  # the bare chain's robot id, apart from every robot of the stack
READY = "ready"  # a relay's first line on stdout
WARMUP = 0.5  # [s] samples published without a stamp (not measured) while routes settle


def hop_key(i: int, control_on: str) -> str:
    """The key relay i reads (0: the publisher's); relay i publishes on hop_key(i + 1)."""
    return keys.key(ROBOT, chain(control_on)[i])


def forward(data: bytes) -> bytes:
    """A relay's whole work on one message: decode it, encode it again."""
    return codec.encode(codec.decode(data, m.Encoders))


def sample(t: float) -> m.Encoders:
    """The message the chain carries for sample t."""
    return m.Encoders(t=t, left=round(t * 1000), right=round(t * 1000))


def relay(connect: str, index: int, mode: str, control_on: str) -> None:
    """Decode every message of hop `index` and publish it on the next, until stdin closes."""
    bus = ZenohBus.open(connect, mode=mode, listen=PEER_LISTEN if mode == "peer" else None)
    out = hop_key(index + 1, control_on)

    def on_msg(key: str, data: bytes) -> None:
        bus.publish(out, forward(data))

    bus.subscribe(hop_key(index, control_on), on_msg)
    print(READY, flush=True)
    sys.stdin.read()  # the measuring process closes it to end the relay
    bus.close()


def pace(start: float, i: float, rate: float) -> None:
    """Sleep until period i from `start` [monotonic s] (pacing, as a sensor does: nothing waits on it)."""
    time.sleep(max(start + i / rate - time.monotonic(), 0.0))


def publish(connect: str, rate: float, duration: float, mode: str = "client") -> None:
    """Publish samples at `rate` [Hz]: WARMUP seconds unstamped, then `duration` seconds stamped, as the sim does."""
    bus = ZenohBus.open(connect, mode=mode, listen=PEER_LISTEN if mode == "peer" else None)
    first, truth = keys.key(ROBOT, chain("odom")[0]), keys.key(ROBOT, "sim/truth")  # the sensor sample, on any chain
    start = time.monotonic()
    warm = int(WARMUP * rate)
    for i in range(warm + int(duration * rate)):
        pace(start, i, rate)  # as the sim's timer does
        t = (i + 1) / rate
        wall = time.time()  # the sample's instant, taken just before it is published (as the sim's)
        bus.publish(first, codec.encode(sample(t)))
        if i >= warm:
            pace(start, i + 0.5, rate)  # as the sim sends a step's truth: half a step after its sensors
            bus.publish(truth, codec.encode(m.Truth(t=t, x=0.0, y=0.0, theta=0.0, v=0.0, omega=0.0, wall=wall)))
    bus.close()


@dataclass(frozen=True)
class Chain:
    """One run of the bare chain."""

    stages: dict[str, list[float]]  # [ms] per stage and end to end, as the observer splits the stack's chain
    relay_cores: float  # [cores] one relay process's CPU over the run (mean of the relays): a hop's floor
    relay_wait: float  # [s] a relay's thread waited for a core each time it got one (mean over the relays' threads)
    relay_runs: float  # [1/s] times one relay's threads got a core (mean of the relays)

    @property
    def latency(self) -> list[float]:
        """[ms] publisher to observer, through every relay."""
        return self.stages[END_TO_END]

    @classmethod
    def pooled(cls, parts: list[Chain]) -> Chain:
        """Several runs as one: their samples together, their relays' mean cost and waits."""
        stages = {name: [x for p in parts for x in p.stages[name]] for name in parts[0].stages}
        figures = zip(*((p.relay_cores, p.relay_wait, p.relay_runs) for p in parts))
        return cls(stages, *(sum(f) / len(parts) for f in figures))


def measure(connect: str, control_on: str, rate: float = 100.0, duration: float = 10.0, mode: str = "client") -> Chain:
    """Start the observer and the relays (the chain `control_on` makes), run the publisher through them."""
    observer = Observer(connect, ROBOT, control_on, mode).start()
    procs = [
        subprocess.Popen(child.argv(relay, connect, i, mode, control_on), stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        for i in range(len(chain(control_on)) - 1)
    ]
    try:
        for p in procs:
            assert p.stdout is not None
            if p.stdout.readline().strip() != READY:
                raise RuntimeError("a chain relay did not start")
        s0, t0 = [read_proc(p.pid) for p in procs], time.monotonic()
        subprocess.run(child.argv(publish, connect, rate, duration, mode), check=True, timeout=duration + 30.0)
        s1, t1 = [read_proc(p.pid) for p in procs], time.monotonic()
        per_relay = len(procs) * (t1 - t0)
        runs = sum(b.runs - a.runs for a, b in zip(s0, s1))
        waited = sum(b.waited - a.waited for a, b in zip(s0, s1))
        cores = sum(b.cpu - a.cpu for a, b in zip(s0, s1)) / per_relay
        return Chain(observer.stages(), cores, waited / max(runs, 1), runs / per_relay)
    finally:
        observer.close()
        for p in procs:
            assert p.stdin is not None
            p.stdin.close()
        for p in procs:
            try:
                p.wait(timeout=10.0)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
            if p.stdout is not None:
                p.stdout.close()
