"""`zenav replay IN.mcap`: publish a recording back onto Zenoh, at its own pace or faster.

IN may be a finished recording or the OUT.mcap.part of a recorder that died.
Exit codes: 0 replayed, 2 bad arguments, config or input file, 3 no router.
"""

from __future__ import annotations

import argparse
import sys

from zenav.cli.checks import Failed, check_recording, check_robot, deployment, fail, note_unfinished
from zenav.cli.main import EXIT_OK, EXIT_USAGE
from zenav.cli.session import open_bus
from zenav.common import keys
from zenav.common.app import deployment_args, stop_on_signals


def add_arguments(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("replay", help="publish an MCAP recording back onto Zenoh (re-run services on recorded input)")
    p.add_argument("input", metavar="IN.mcap", help="a recording made by `zenav record` (or its .part if the recorder died)")
    deployment_args(p)
    p.add_argument("--from-robot", help="replay only this recorded robot (default: every robot in the file)")
    p.add_argument("--rate", type=float, default=1.0, help="speed-up over the recorded pace; 0 = as fast as possible (default 1)")
    p.add_argument(
        "--topics",
        help="comma-separated topic suffixes to replay (default: all), e.g. clock,odom,vps/pose,sensors/imu to re-run the localizer",
    )
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from zenav.tools.replay import replay  # optional dependencies: imported when used

    suffixes = [s.strip() for s in args.topics.split(",") if s.strip()] if args.topics else None
    try:
        unknown = sorted(set(suffixes or ()) - set(keys.TOPICS))
        if unknown:
            raise Failed(EXIT_USAGE, f"unknown topics: {', '.join(unknown)}")
        if not args.rate >= 0:
            raise Failed(EXIT_USAGE, "--rate must be >= 0")
        check_robot(args.from_robot, "--from-robot")
        deployment(args)  # --config, --set: valid, although replay needs only --robot and --connect
        finished = check_recording(args.input)
        check_robots(args.input, args.from_robot, args.robot)
        bus = open_bus(args)
    except Failed as e:
        return fail("replay", e)
    if not finished:
        note_unfinished("replay", args.input)
    stop = stop_on_signals()
    try:
        # Published as the recorded robots, unless --robot (or ZENAV_ROBOT) names one.
        sent = replay(args.input, bus, args.rate, robot=args.from_robot, as_robot=args.robot, suffixes=suffixes, stop=stop)
    finally:
        bus.close()
    print(f"{args.input}: {sent} messages replayed" + (" (stopped)" if stop.is_set() else ""), file=sys.stderr)
    return EXIT_OK


def check_robots(path: str, source: str | None, target: str | None) -> None:
    """Failed(EXIT_USAGE) if --from-robot names a robot the recording does not hold, or if --robot would
    publish several recorded robots as one."""
    from zenav.tools import mcap_format as fmt

    held = fmt.robots(path)
    if source is not None and source not in held:
        raise Failed(EXIT_USAGE, f"{path} holds no robot {source} (it holds {', '.join(held) or 'none'})")
    if source is None and target is not None and len(held) > 1:
        raise Failed(
            EXIT_USAGE,
            f"{path} holds robots {', '.join(held)}: --robot (or ZENAV_ROBOT) {target} would publish them all as one; "
            "pick one with --from-robot, or give neither to publish each as recorded",
        )
