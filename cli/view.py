"""`zenav view`: a live Foxglove view of a robot (foxglove-sdk WebSocket server)."""
from __future__ import annotations

import argparse
import sys

from zenav.cli.main import EXIT_OK
from zenav.common.app import deployment_args, stop_on_signals
from zenav.common.bus import ZenohBus


def add_arguments(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("view", help="serve a robot's truth, odom, fused pose, fixes, goal and state to the Foxglove app")
    deployment_args(p)
    p.add_argument("--host", help="address to listen on (default 127.0.0.1: loopback only)")
    p.add_argument("--port", type=int, help="WebSocket port (default 8765)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from zenav.tools.view import DEFAULT_HOST, DEFAULT_PORT, View  # optional dependencies: imported when used

    bus = ZenohBus.open(args.connect)
    done = stop_on_signals()
    try:
        host = args.host or DEFAULT_HOST
        view = View(bus, args.robot or "r1", host, args.port or DEFAULT_PORT).start()
        print(
            f"zenav view of robot {view.robot} on ws://{host}:{view.port}\n"
            f"  Foxglove: Open connection > Foxglove WebSocket > ws://{host}:{view.port}, or {view.app_url()}\n"
            "  layout: docs/foxglove-layout.json (Layouts > Import from file); Ctrl-C to stop",
            file=sys.stderr,
            flush=True,
        )
        done.wait()
        view.stop()
    finally:
        bus.close()
    return EXIT_OK
