"""`zenav record OUT.mcap`: every zenav topic of a robot (or of all robots) to an MCAP file."""
from __future__ import annotations

import argparse
import sys

from zenav.cli.main import EXIT_FAILED, EXIT_OK
from zenav.common.app import deployment_args, stop_on_signals
from zenav.common.bus import ZenohBus


def add_arguments(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("record", help="record a robot's topics to MCAP (Foxglove, mcap tools) until Ctrl-C")
    p.add_argument("out", metavar="OUT.mcap", help="file to write (replaced if it exists)")
    deployment_args(p)
    p.add_argument("--all", action="store_true", help="record every robot on the network (zenav/*/**)")
    p.add_argument("--duration", type=float, help="stop by itself after this many wall seconds")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from zenav.tools.record import Recorder  # optional dependencies: imported when used

    bus = ZenohBus.open(args.connect)
    done = stop_on_signals()
    try:
        rec = Recorder(args.out, bus, None if args.all else (args.robot or "r1")).start()
        print(f"recording {rec.keyexpr} to {args.out}; Ctrl-C to stop", file=sys.stderr, flush=True)
        done.wait(args.duration)
        rec.stop()
    except OSError as e:
        print(f"zenav record: {e}", file=sys.stderr)
        return EXIT_FAILED
    finally:
        bus.close()
    print(
        f"{args.out}: {sum(rec.counts.values())} messages on {len(rec.counts)} topics over {rec.duration:.1f} s"
        + (f"; {rec.dropped} dropped (writer behind)" if rec.dropped else ""),
        file=sys.stderr,
    )
    return EXIT_OK
