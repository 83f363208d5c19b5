"""The embedded Zenoh router: opened in this process, or run as its own process.

`python -m zenav.stack.router --listen EP` is the router process a launcher starts
(`zenav router` runs the same `serve`).
"""

from __future__ import annotations

import argparse
import ipaddress
import json
from collections.abc import Callable

import zenoh

from zenav.common.app import normal_priority, realtime, stop_on_signals
from zenav.common.bus import zenoh_config
from zenav.common.config import Limits
from zenav.common.keys import DEFAULT_CONNECT
from zenav.stack.inprocess import free_port

DEFAULT_LISTEN = DEFAULT_CONNECT  # where the stack and its tools meet
MAX_MESSAGE = Limits().max_message()  # [bytes] the default [limits]' largest message: larger ones stop at the router

# [s] how long a router that spans hosts waits to queue a message for a link before it closes the link (Zenoh's
# default: 5 s). A host whose cable is out, or whose Wi-Fi went, closes no socket: the router's queue for it fills
# (the sim's camera frames fill it within a second) and would hold up every message, the robot's loop's too, until
# then. The host's router links again when it is back.
BLOCKED_LINK = 0.25


def exposed(listen: str) -> list[str]:
    """The endpoints of `listen` that other hosts can reach (not loopback, not a unix socket)."""
    out = []
    for ep in (e.strip() for e in listen.split(",") if e.strip()):
        if ep.startswith("unixsock"):
            continue
        host = ep.split("/", 1)[-1].rsplit(":", 1)[0].strip("[]")
        try:
            loopback = ipaddress.ip_address(host).is_loopback
        except ValueError:
            loopback = host == "localhost"
        if not loopback:
            out.append(ep)
    return out


def open_router(
    listen: str, config_file: str | None = None, priority: int = 0, connect: str | None = None, max_message: int = MAX_MESSAGE
) -> zenoh.Session:
    """Open a router session; SystemExit with a clear message if the port is taken. `priority` (`[deployment]
    realtime`; 0: none): the SCHED_FIFO priority of the threads Zenoh starts meanwhile, which are all of them when
    it is the process's first session (the calling thread keeps its own). `connect`: the endpoints (comma-separated)
    of other hosts' routers to link to, tried again every half second while one is not there (it opens at once). A
    message over `max_message` bytes is dropped as it arrives (Zenoh's transport/link/rx/max_message_size, set over any
    `config_file`'s)."""
    raised = priority > 0 and realtime(priority, "router") is None
    conf = zenoh_config("router", connect=connect, listen=listen, config_file=config_file, max_message=max_message)
    if connect or exposed(listen):  # other hosts' routers link to it, or it to theirs
        conf.insert_json5("transport/link/tx/queue/congestion_control/block/wait_before_close", json.dumps(round(BLOCKED_LINK * 1e6)))
    try:
        return zenoh.open(conf)
    except zenoh.ZError as e:
        raise SystemExit(f"zenav: cannot listen on {listen} ({e}); is another router running there?") from None
    finally:
        if raised:
            normal_priority()


def serve(
    listen: str,
    config_file: str | None = None,
    ready: Callable[[], None] = lambda: None,
    priority: int = 0,
    connect: str | None = None,
    max_message: int = MAX_MESSAGE,
) -> None:
    """Run a router until SIGINT or SIGTERM (linked to the routers at `connect`); `ready` is called once it listens."""
    done = stop_on_signals()  # before the router listens: a launcher may stop it as soon as it does
    session = open_router(listen, config_file, priority, connect, max_message)
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
    parser.add_argument("--max-message", type=int, default=MAX_MESSAGE, help="[bytes] larger messages are dropped as they arrive")
    args = parser.parse_args(argv)
    serve(args.listen, priority=args.realtime, max_message=args.max_message)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
