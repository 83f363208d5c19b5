"""`zenav record OUT.mcap`: every zenav topic of a robot (or of all robots) to an MCAP file.

The file is written as OUT.mcap.part and renamed to OUT.mcap when the recording
stops cleanly (Ctrl-C, SIGTERM, SIGHUP, --duration). If the process dies instead,
OUT.mcap.part stays, readable by `zenav plot` and `zenav replay` up to about a
second before the end. With --ros2, OUT is a ROS 2 bag directory instead (rosbag2's
MCAP storage, CDR messages: `ros2 bag play OUT`). Exit codes: 0 recorded, 1 the file
could not be written, 2 bad arguments or config (or the ros2 extra missing), 3 no router.
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
from typing import Any

from zenav.cli.checks import Failed, deployment, fail
from zenav.cli.main import EXIT_FAILED, EXIT_OK, EXIT_USAGE
from zenav.cli.session import open_bus
from zenav.common.app import deployment_args, stop_on_signals


def add_arguments(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("record", help="record a robot's topics to MCAP (Foxglove, mcap tools) until Ctrl-C")
    p.add_argument("out", metavar="OUT.mcap", help="file to write (replaced if it exists), as OUT.mcap.part until finished")
    deployment_args(p)
    p.add_argument("--all", action="store_true", help="record every robot on the network (zenav/*/**)")
    p.add_argument("--duration", type=float, help="stop by itself after this many wall seconds")
    p.add_argument("--ros2", action="store_true", help="write OUT as a ROS 2 bag directory (MCAP, CDR) for ros2 bag play; one robot")
    p.add_argument(
        "--distro",
        default=os.environ.get("ROS_DISTRO") or "jazzy",
        help="with --ros2: the ROS 2 distro whose message definitions to write (humble, jazzy, kilted; env ROS_DISTRO; default jazzy)",
    )
    p.set_defaults(func=run)


def check_out(out: str, part: str) -> None:
    """Failed(EXIT_USAGE) unless `out` can be a new file, written as `part`, which no crashed recording holds."""
    folder = os.path.dirname(os.path.abspath(out))
    if os.path.isdir(out) or not os.path.isdir(folder):
        raise Failed(EXIT_USAGE, f"{out}: not a file in an existing directory")
    if not os.access(folder, os.W_OK):
        raise Failed(EXIT_USAGE, f"{out}: directory {folder} is not writable")
    if os.path.exists(part):
        raise Failed(EXIT_USAGE, f"{part} exists (a recording not closed cleanly): move it away first")


def check_bag(out: str, distro: str, all_robots: bool) -> None:
    """Failed(EXIT_USAGE) unless `out` can be a new bag directory of one robot, in a known distro."""
    folder = os.path.dirname(os.path.abspath(out))
    if os.path.exists(out) or not os.path.isdir(folder):
        raise Failed(EXIT_USAGE, f"{out}: with --ros2, a new directory (the bag) in an existing one")
    if not os.access(folder, os.W_OK):
        raise Failed(EXIT_USAGE, f"{out}: directory {folder} is not writable")
    if all_robots:
        raise Failed(EXIT_USAGE, "--ros2 records one robot: leave out --all")
    if distro.lower() not in ("humble", "jazzy", "kilted"):
        raise Failed(EXIT_USAGE, f"--distro (or ROS_DISTRO) {distro!r}: expected one of humble, jazzy, kilted")


def _recorder(args: argparse.Namespace, bus: Any, robot: str) -> Any:
    if args.ros2:
        from zenav.tools.record_ros2 import Ros2Recorder  # optional dependency (rosbags): imported when used

        return Ros2Recorder(args.out, bus, robot, args.distro.lower())
    from zenav.tools.record import Recorder

    return Recorder(args.out, bus, None if args.all else robot)


def run(args: argparse.Namespace) -> int:
    from zenav.tools.mcap_format import PART  # optional dependencies: imported when used

    try:
        if args.duration is not None and not args.duration > 0:
            raise Failed(EXIT_USAGE, "--duration must be > 0")
        if args.ros2:
            check_bag(args.out, args.distro, args.all)
            try:
                import rosbags  # noqa: F401  (the ros2 extra)
            except ImportError:
                raise Failed(EXIT_USAGE, "--ros2 needs the optional package 'rosbags': pip install 'zenav[ros2]'") from None
        else:
            check_out(args.out, args.out + PART)
        dep = deployment(args)
        bus = open_bus(args)
    except Failed as e:
        return fail("record", e)
    done = stop_on_signals((signal.SIGINT, signal.SIGTERM, signal.SIGHUP))  # a closed terminal finishes the file too
    try:
        rec = _recorder(args, bus, dep.robot).start()
        print(f"recording {rec.keyexpr} to {args.out if args.ros2 else rec.part}; Ctrl-C to stop", file=sys.stderr, flush=True)
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
