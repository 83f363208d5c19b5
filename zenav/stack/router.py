"""The embedded Zenoh router: opened in this process, or run as its own process.

`python -m zenav.stack.router --listen EP` is the router process a launcher starts
(`zenav router` runs the same `serve`).
"""

from __future__ import annotations

import argparse

import zenoh

from zenav.common.app import normal_priority, realtime, stop_on_signals
from zenav.common.bus import zenoh_config
from zenav.common.keys import DEFAULT_CONNECT
from zenav.stack.inprocess import free_port

DEFAULT_LISTEN = DEFAULT_CONNECT  # where the stack and its tools meet


def open_router(listen: str, config_file: str | None = None, priority: int = 0, connect: str | None = None) -> zenoh.Session:
    """Open a router session; SystemExit with a clear message if the port is taken. `priority` (`[deployment]
    realtime`; 0: none): the SCHED_FIFO priority of the threads Zenoh starts meanwhile, which are all of them when
    it is the process's first session (the calling thread keeps its own). `connect`: the endpoints (comma-separated)
    of other hosts' routers to link to, tried again every half second while one is not there (it opens at once)."""
    raised = priority > 0 and realtime(priority, "router") is None
    try:
        return zenoh.open(zenoh_config("router", connect=connect, listen=listen, config_file=config_file))
    except zenoh.ZError as e:
        raise SystemExit(f"zenav: cannot listen on {listen} ({e}); is another router running there?") from None
    finally:
        if raised:
            normal_priority()


def serve(listen: str, config_file: str | None = None, ready=lambda: None, priority: int = 0, connect: str | None = None) -> None:
    """Run a router until SIGINT or SIGTERM (linked to the routers at `connect`); `ready` is called once it listens."""
    done = stop_on_signals()  # before the router listens: a launcher may stop it as soon as it does
    session = open_router(listen, config_file, priority, connect)
    ready()
    done.wait()
    session.close()


class Router:
    """A Zenoh router in this process, listening on loopback (a free port unless given)."""

    def __init__(self, port: int | None = None) -> None:
        self.endpoint = f"tcp/127.0.0.1:{port or free_port()}"
        self.session = open_router(self.endpoint)

    def close(self) -> None:
        """Close the router's session (idempotent)."""
        if not self.session.is_closed():
            self.session.close()

    def __enter__(self) -> Router:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def main(argv: list[str] | None = None) -> int:
    """The router process of a launcher."""
    parser = argparse.ArgumentParser(prog="python -m zenav.stack.router", description="a Zenoh router until SIGTERM")
    parser.add_argument("--listen", required=True, help="endpoint(s), comma-separated")
    parser.add_argument("--realtime", type=int, default=0, help="SCHED_FIFO priority of its Zenoh threads (0: normal)")
    args = parser.parse_args(argv)
    serve(args.listen, priority=args.realtime)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
