"""`zenav router`: a Zenoh router (a Python process in router mode)."""
from __future__ import annotations

import argparse
import sys

import zenoh

from zenav.common.app import stop_on_signals
from zenav.common.bus import zenoh_config

DEFAULT_LISTEN = "tcp/127.0.0.1:7447"


def add_arguments(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("router", help="run a Zenoh router until Ctrl-C")
    p.add_argument("--listen", default=DEFAULT_LISTEN, help=f"endpoint(s), comma-separated (default {DEFAULT_LISTEN})")
    p.add_argument("--zenoh-config", help="a Zenoh JSON5 config to start from (auth, access control)")
    p.set_defaults(func=run)


def open_router(listen: str, config_file: str | None = None) -> zenoh.Session:
    """Open a router session; SystemExit with a clear message if the port is taken."""
    try:
        return zenoh.open(zenoh_config("router", listen=listen, config_file=config_file))
    except zenoh.ZError as e:
        raise SystemExit(f"zenav: cannot listen on {listen} ({e}); is another router running there?") from None


def run(args: argparse.Namespace) -> int:
    session = open_router(args.listen, args.zenoh_config)
    print(f"zenav router listening on {args.listen}", file=sys.stderr, flush=True)
    done = stop_on_signals()
    done.wait()
    session.close()
    return 0
