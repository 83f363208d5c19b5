"""`zenav router`: a Zenoh router (a Python process in router mode)."""

from __future__ import annotations

import argparse
import ipaddress
import os
import sys

from zenav.stack.router import DEFAULT_LISTEN, MAX_MESSAGE, serve


def add_arguments(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("router", help="run a Zenoh router until Ctrl-C")
    p.add_argument("--listen", default=DEFAULT_LISTEN, help=f"endpoint(s), comma-separated (default {DEFAULT_LISTEN})")
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


def exposed(listen: str) -> list[str]:
    """The endpoints of `listen` that other hosts can reach (not loopback)."""
    out = []
    for ep in (e.strip() for e in listen.split(",") if e.strip()):
        host = ep.split("/", 1)[-1].rsplit(":", 1)[0].strip("[]")
        try:
            loopback = ipaddress.ip_address(host).is_loopback
        except ValueError:
            loopback = host == "localhost"
        if not loopback:
            out.append(ep)
    return out


def run(args: argparse.Namespace) -> int:
    open_to = exposed(args.listen)
    if open_to and not (args.zenoh_config or os.environ.get("ZENOH_CONFIG")):
        print(
            f"zenav router: warning: {', '.join(open_to)} is open to other hosts with no login or access control "
            "(anyone there can drive the robot); see docs/running.md for the secure deployment",
            file=sys.stderr,
        )
    if args.max_message < 1024:
        print(f"zenav router: --max-message {args.max_message}: at least 1024 bytes", file=sys.stderr)
        return 2
    if not 0 <= args.realtime <= 99:
        print(f"zenav router: --realtime {args.realtime}: a priority from 1 to 99, or 0", file=sys.stderr)
        return 2

    def ready() -> None:
        print(f"zenav router listening on {args.listen}", file=sys.stderr, flush=True)

    serve(args.listen, args.zenoh_config, ready=ready, priority=args.realtime, max_message=args.max_message)
    return 0
