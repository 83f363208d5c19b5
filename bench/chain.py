"""The floor the sensor-to-wheel chain is compared with: the same five hops with no service work.

A publisher (bench/rawhop.py's: Clock messages stamped with the wall clock, paced
like the sim), RELAYS relay processes that only decode each message and publish it
again on the next key, and a subscriber that takes arrival minus send [ms]: five
hops, as sim -> odometry -> localizer -> navigator -> motor -> observer, with the
same codec, publisher settings, router and Zenoh mode as the stack.

`python -m zenav.bench.chain relay --connect EP --index 0` runs one relay.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from dataclasses import dataclass

from zenav.bench import rawhop
from zenav.common import codec, keys
from zenav.common import messages as m
from zenav.common.app import PEER_LISTEN
from zenav.common.bus import ZenohBus
from zenav.stack.launcher import read_proc

RELAYS = 4  # relay processes: with the publisher and the subscriber, five hops
READY = "ready"  # a relay's first line on stdout


def hop_key(i: int) -> str:
    """The key relay i reads (0: the publisher's); relay i publishes on hop_key(i + 1)."""
    return keys.key(rawhop.ROBOT, "clock") if i == 0 else keys.key(rawhop.ROBOT, f"chain/{i}")


def forward(data: bytes) -> bytes:
    """A relay's whole work on one message: decode it, encode it again."""
    return codec.encode(codec.decode(data, m.Clock))


def relay(connect: str, index: int, mode: str) -> None:
    """Decode every message of hop `index` and publish it on the next, until stdin closes."""
    bus = ZenohBus.open(connect, mode=mode, listen=PEER_LISTEN if mode == "peer" else None)
    out = hop_key(index + 1)

    def on_msg(key: str, data: bytes) -> None:
        bus.publish(out, forward(data))

    bus.subscribe(hop_key(index), on_msg)
    print(READY, flush=True)
    sys.stdin.read()  # the measuring process closes it to end the relay
    bus.close()


@dataclass(frozen=True)
class Chain:
    """One run of the bare chain."""

    latency: list[float]  # [ms] publisher to subscriber, through every relay
    relay_cores: float  # [cores] one relay process's CPU over the run (mean of the relays): a hop's floor

    @classmethod
    def pooled(cls, parts: list[Chain]) -> Chain:
        """Several runs as one: their samples together, their relays' mean cost."""
        return cls([x for p in parts for x in p.latency], sum(p.relay_cores for p in parts) / len(parts))


def measure(connect: str, rate: float = 100.0, duration: float = 10.0, mode: str = "client") -> Chain:
    """Start the relays, run the publisher and subscriber through them."""
    base = [sys.executable, "-m", "zenav.bench.chain", "relay", "--connect", connect, "--mode", mode]
    procs = [subprocess.Popen(base + ["--index", str(i)], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True) for i in range(RELAYS)]
    try:
        for p in procs:
            assert p.stdout is not None
            if p.stdout.readline().strip() != READY:
                raise RuntimeError("a chain relay did not start")
        cpu0, t0 = [read_proc(p.pid).cpu for p in procs], time.monotonic()
        latency = rawhop.measure(connect, rate, duration, listen=hop_key(RELAYS), mode=mode)
        cpu1, t1 = [read_proc(p.pid).cpu for p in procs], time.monotonic()
        return Chain(latency, sum(b - a for a, b in zip(cpu0, cpu1)) / len(procs) / (t1 - t0))
    finally:
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


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m zenav.bench.chain", description=__doc__.splitlines()[0])
    parser.add_argument("role", choices=("relay",))
    parser.add_argument("--connect", required=True, help="router endpoint")
    parser.add_argument("--index", type=int, required=True, help="which hop this relay reads (0: the publisher's)")
    parser.add_argument("--mode", default="client", choices=("client", "peer"), help="Zenoh mode, as the stack's services")
    args = parser.parse_args(argv)
    relay(args.connect, args.index, args.mode)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
