"""`zenav router`: a Zenoh router (a Python process in router mode)."""

from __future__ import annotations

import argparse
import os
import sys

from zenav.stack.router import DEFAULT_LISTEN, MAX_MESSAGE, exposed, serve


def add_arguments(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("router", help="run a Zenoh router until Ctrl-C")
    p.add_argument("--listen", default=DEFAULT_LISTEN, help=f"endpoint(s), comma-separated (default {DEFAULT_LISTEN})")
    p.add_argument(
        "--connect",
        metavar="ENDPOINTS",
        help="link to the routers at these endpoints, comma-separated (another host's: tcp/10.0.0.1:7447); retried while one is away",
    )
    p.add_argument("--zenoh-config", help="a Zenoh JSON5 config to start from (auth, access control)")
    p.add_argument(
        "--realtime",
        type=int,
        default=0,
        metavar="PRIORITY",
        help="run its Zenoh threads at SCHED_FIFO PRIORITY, 1 to 99 (default 0: normal)",
    )
    p.add_argument(
        "--max-message",
        type=int,
        default=MAX_MESSAGE,
        metavar="BYTES",
        help=f"drop larger messages as they arrive (default {MAX_MESSAGE}: the default [limits] max_payload plus max_params plus"
        " 64 KiB; raise it with them)",
    )
    p.set_defaults(func=run)


def warn_if_open(prog: str, listen: str, config_file: str | None = None) -> None:
    """Warn on stderr when `listen` reaches other hosts and no Zenoh config (logins, access control) is given."""
    open_to = exposed(listen)
    if open_to and not (config_file or os.environ.get("ZENOH_CONFIG")):
        print(
            f"{prog}: warning: {', '.join(open_to)} is open to other hosts with no login or access control "
            "(anyone there can drive the robot); see docs/running.md for the secure deployment",
            file=sys.stderr,
        )


def run(args: argparse.Namespace) -> int:
    warn_if_open("zenav router", args.listen, args.zenoh_config)
    if args.max_message < 1024:
        print(f"zenav router: --max-message {args.max_message}: at least 1024 bytes", file=sys.stderr)
        return 2
    if not 0 <= args.realtime <= 99:
        print(f"zenav router: --realtime {args.realtime}: a priority from 1 to 99, or 0", file=sys.stderr)
        return 2

    def ready() -> None:
        linked = f", linking to {args.connect}" if args.connect else ""
        print(f"zenav router listening on {args.listen}{linked}", file=sys.stderr, flush=True)

    serve(args.listen, args.zenoh_config, ready=ready, priority=args.realtime, connect=args.connect, max_message=args.max_message)
    return 0
