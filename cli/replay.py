"""`zenav replay IN.mcap`: publish a recording back onto Zenoh, at its own pace or faster."""
from __future__ import annotations

import argparse
import os
import sys

from zenav.cli.main import EXIT_FAILED, EXIT_OK, EXIT_USAGE
from zenav.common import keys
from zenav.common.app import deployment_args, stop_on_signals
from zenav.common.bus import ZenohBus


def add_arguments(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("replay", help="publish an MCAP recording back onto Zenoh (re-run services on recorded input)")
    p.add_argument("input", metavar="IN.mcap", help="a recording made by `zenav record`")
    deployment_args(p)
    p.add_argument("--from-robot", help="replay only this recorded robot (default: every robot in the file)")
    p.add_argument("--rate", type=float, default=1.0, help="speed-up over the recorded pace; 0 = as fast as possible (default 1)")
    p.add_argument(
        "--topics",
        help="comma-separated topic suffixes to replay (default: all), e.g. clock,odom,vps/pose to re-run the localizer",
    )
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from zenav.tools.replay import replay  # optional dependencies: imported when used

    suffixes = [s.strip() for s in args.topics.split(",") if s.strip()] if args.topics else None
    unknown = sorted(set(suffixes or ()) - set(keys.TOPICS))
    if unknown:
        print(f"zenav replay: unknown topics: {', '.join(unknown)}", file=sys.stderr)
        return EXIT_USAGE
    if args.rate < 0:
        print("zenav replay: --rate must be >= 0", file=sys.stderr)
        return EXIT_USAGE
    if not os.path.isfile(args.input):
        print(f"zenav replay: no such file: {args.input}", file=sys.stderr)
        return EXIT_FAILED
    bus = ZenohBus.open(args.connect)
    stop = stop_on_signals()
    try:
        sent = replay(args.input, bus, args.rate, robot=args.from_robot, as_robot=args.robot, suffixes=suffixes, stop=stop)
    finally:
        bus.close()
    print(f"{args.input}: {sent} messages replayed" + (" (stopped)" if stop.is_set() else ""), file=sys.stderr)
    return EXIT_OK
