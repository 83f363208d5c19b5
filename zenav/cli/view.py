"""`zenav view`: a live Foxglove view of a robot (foxglove-sdk WebSocket server).

Exit codes: 0 stopped by Ctrl-C, 1 the server could not start (port taken),
2 bad arguments or config, 3 no router.
"""

from __future__ import annotations

import argparse
import sys
from importlib.resources import files

from zenav.cli.checks import Failed, deployment, fail
from zenav.cli.main import EXIT_FAILED, EXIT_OK, EXIT_USAGE
from zenav.cli.session import open_bus
from zenav.common.app import deployment_args, stop_on_signals


def add_arguments(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("view", help="serve a robot's truth, odom, fused pose, fixes, goal and state to the Foxglove app")
    deployment_args(p)
    p.add_argument("--host", help="address to listen on (default 127.0.0.1: loopback only)")
    p.add_argument("--port", type=int, help="WebSocket port (default 8765)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from zenav.tools.view import DEFAULT_HOST, DEFAULT_PORT, View  # optional dependencies: imported when used

    host = args.host or DEFAULT_HOST
    port = DEFAULT_PORT if args.port is None else args.port
    try:
        if not 0 <= port <= 65535:
            raise Failed(EXIT_USAGE, f"--port {port}: not a port number (0-65535)")
        dep = deployment(args)
        bus = open_bus(args)
    except Failed as e:
        return fail("view", e)
    done = stop_on_signals()
    try:
        try:
            view = View(bus, dep.robot, host, port).start()
        except RuntimeError as e:  # the server cannot listen there
            print(f"zenav view: cannot serve on {host}:{port} ({e})", file=sys.stderr)
            return EXIT_FAILED
        print(
            f"zenav view of robot {view.robot} on ws://{host}:{view.port}\n"
            f"  Foxglove: Open connection > Foxglove WebSocket > ws://{host}:{view.port}, or {view.app_url()}\n"
            f"  layout: {files('zenav') / 'data' / 'foxglove-layout.json'} (Layouts > Import from file); Ctrl-C to stop",
            file=sys.stderr,
            flush=True,
        )
        done.wait()
        view.stop()
    finally:
        bus.close()
    return EXIT_OK
