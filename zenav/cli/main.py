"""The `zenav` command: one subcommand per module of zenav.cli."""

from __future__ import annotations

import argparse
import importlib
import os
import select
import sys
from collections.abc import Sequence

from zenav import __version__
from zenav.common import extras

# Subcommand modules; each defines add_arguments(subparsers) and sets `func` on its parsers.
MODULES = (
    "up",
    "router",
    "status",
    "nav",
    "watch",
    "record",
    "replay",
    "view",
    "plot",
    "bench",
    "calibrate",
    "camera",
    "introspect",
    "teleop",
    "completion",
    "ros2",
)

EXIT_OK, EXIT_FAILED, EXIT_USAGE, EXIT_UNAVAILABLE = 0, 1, 2, 3
ENVIRONMENT = """environment:
  ZENAV_ROBOT     robot id (--robot; default r1)
  ZENOH_CONNECT   router endpoint(s) (--connect; default tcp/127.0.0.1:7447)
  ZENOH_MODE      client or peer (--zenoh-mode; default client)
  ZENOH_CONFIG    a full Zenoh JSON5 config to start from (auth, access control)
  ZENAV_CONFIG    config file of `zenav up` and the services (--config);
                  ZENAV_SCENARIO and ZENAV_SEED likewise (--scenario, --seed)
  ZENAV_LOG       log level of the service processes: DEBUG, INFO (default), WARNING, ERROR;
                  `zenav up` passes it on to every service it starts

exit codes: 0 done, 1 failed (goal aborted or cancelled...), 2 bad arguments or config, 3 no router or service unavailable"""


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="zenav",
        description="Localization and navigation for a differential-drive robot over Zenoh.",
        epilog=ENVIRONMENT,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"zenav {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in MODULES:
        importlib.import_module(f"zenav.cli.{name}").add_arguments(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        code = int(args.func(args) or 0)
        sys.stdout.flush()  # here, not at exit: a reader that left must be met below
        return code
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:
        if not reader_gone(sys.stdout.fileno()):
            raise  # a pipe other than the output broke: a failure to show
        # `zenav status | head -4`: the reader has what it wanted. Python's last flush of
        # stdout at exit must not fail again with a traceback.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_OK
    except extras.MissingExtra as e:  # a feature's optional package is not installed: one line naming its extra
        print(f"zenav {args.command}: {e}", file=sys.stderr)
        return EXIT_USAGE
    except ImportError as e:  # a module importing an optional package at its top (recording, view, plots: zenav[tools])
        missing = extras.missing_of(e, "this command")
        if missing is None:
            raise
        print(f"zenav {args.command}: {missing}", file=sys.stderr)
        return EXIT_USAGE


def reader_gone(fd: int) -> bool:
    """Whether the pipe or socket `fd` writes to has no reader left (poll reports an error on it)."""
    poller = select.poll()
    poller.register(fd, select.POLLOUT)
    return any(ev & (select.POLLERR | select.POLLHUP) for _, ev in poller.poll(0))


if __name__ == "__main__":
    sys.exit(main())
