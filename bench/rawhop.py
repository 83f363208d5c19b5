"""The bare Zenoh hop the stack is compared with: two plain Python processes, no services.

`python -m zenav.bench.rawhop pub --connect EP --rate 100 --duration 10` publishes
Clock messages stamped with the wall clock; `... sub --connect EP` prints, as JSON,
arrival minus send time of each one [ms]. Same codec, same publisher settings and
same router as the stack, so only the services' own work is left out.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import threading
import time

from zenav.common import codec, keys
from zenav.common import messages as m
from zenav.common.app import PEER_LISTEN
from zenav.common.bus import ZenohBus

ROBOT = "rawhop"  # key prefix of the raw hop, apart from every robot of the stack
WARMUP = 0.5  # [s] published before the measured samples, while routes settle
READY = "ready"  # the subscriber's first line on stdout


def publish(connect: str, rate: float, duration: float, mode: str = "client") -> None:
    """Publish Clock messages at `rate` [Hz] for WARMUP + `duration` seconds, then an end marker."""
    bus = ZenohBus.open(connect, mode=mode, listen=PEER_LISTEN if mode == "peer" else None)
    key = keys.key(ROBOT, "clock")
    start = time.monotonic()
    n_total = int((WARMUP + duration) * rate)
    for i in range(n_total):
        delay = start + i / rate - time.monotonic()
        if delay > 0:
            time.sleep(delay)  # pacing the publisher, as the sim's timer does
        t = max(i / rate - WARMUP, 0.0)  # negative (warm-up) samples all carry t = 0
        bus.publish(key, codec.encode(m.Clock(t=t, rtf=1.0, wall=time.time())))
    bus.publish(keys.key(ROBOT, "end"), b"")
    bus.close()


def subscribe(connect: str, timeout: float, key: str | None = None, mode: str = "client") -> list[float]:
    """Collect arrival minus send [ms] of every measured sample on `key` (the publisher's) until the end marker."""
    bus = ZenohBus.open(connect, mode=mode, listen=PEER_LISTEN if mode == "peer" else None)
    out: list[float] = []
    done = threading.Event()

    def on_clock(key: str, data: bytes) -> None:
        arrival = time.time()
        msg = codec.decode(data, m.Clock)
        if msg.t > 0.0:
            out.append((arrival - msg.wall) * 1e3)

    bus.subscribe(key or keys.key(ROBOT, "clock"), on_clock)
    bus.subscribe(keys.key(ROBOT, "end"), lambda key, data: done.set())
    print(READY, flush=True)
    done.wait(timeout)
    bus.close()
    return out


def measure(connect: str, rate: float = 100.0, duration: float = 10.0, listen: str | None = None, mode: str = "client") -> list[float]:
    """Run the subscriber and the publisher as two processes; the hop latencies [ms].

    `listen`: the key the subscriber reads (default the publisher's; bench/chain.py's relays move it on)."""
    base = [sys.executable, "-m", "zenav.bench.rawhop"]
    sub_args = ["sub", "--connect", connect, "--timeout", str(duration + 30.0), "--mode", mode] + (["--key", listen] if listen else [])
    sub = subprocess.Popen(base + sub_args, stdout=subprocess.PIPE, text=True)
    lines = sub.stdout
    assert lines is not None  # stdout=PIPE
    try:
        if lines.readline().strip() != READY:
            raise RuntimeError("raw hop subscriber did not start")
        subprocess.run(
            base + ["pub", "--connect", connect, "--rate", str(rate), "--duration", str(duration), "--mode", mode],
            check=True,
            timeout=duration + 30.0,
        )
        out, _ = sub.communicate(timeout=30.0)
    finally:
        if sub.poll() is None:
            sub.kill()
            sub.wait()
        lines.close()
    return json.loads(out)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m zenav.bench.rawhop", description=__doc__.splitlines()[0])
    parser.add_argument("role", choices=("pub", "sub"))
    parser.add_argument("--connect", required=True, help="router endpoint")
    parser.add_argument("--rate", type=float, default=100.0, help="[Hz] publisher rate")
    parser.add_argument("--duration", type=float, default=10.0, help="[s] measured publishing time")
    parser.add_argument("--timeout", type=float, default=60.0, help="[s] subscriber gives up after this")
    parser.add_argument("--key", help="key the subscriber reads (default the publisher's)")
    parser.add_argument("--mode", default="client", choices=("client", "peer"), help="Zenoh mode")
    args = parser.parse_args(argv)
    if args.role == "pub":
        publish(args.connect, args.rate, args.duration, args.mode)
    else:
        print(json.dumps([round(x, 4) for x in subscribe(args.connect, args.timeout, args.key, args.mode)]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
