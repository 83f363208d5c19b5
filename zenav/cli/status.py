"""`zenav status`: services, rates, counters and the navigator's state, from any terminal."""

from __future__ import annotations

import argparse
import sys
import time

from zenav import services
from zenav.cli.checks import Failed, fail
from zenav.cli.main import EXIT_OK, EXIT_UNAVAILABLE
from zenav.cli.screen import pose_line, service_rows
from zenav.cli.session import open_bus, positive, robot_id
from zenav.common.app import connection_args
from zenav.common.client import Client, ZenavError


def add_arguments(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("status", help="services, rates, counters and navigation state of a running stack")
    connection_args(p)
    p.add_argument("--timeout", type=positive, default=2.0, help="seconds to collect diag (default 2; diag is 1 Hz)")
    p.add_argument(
        "--service",
        action="append",
        choices=services.ALL,
        metavar="NAME",
        help="only whether this service holds its liveliness token (repeatable): exit 0 if each named does, else 3 (a healthcheck)",
    )
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    try:
        robot = robot_id(args)
        bus = open_bus(args)
    except Failed as e:
        return fail("status", e)
    try:
        if args.service:
            return check_alive(Client(robot, bus=bus), args.service)
        return report(Client(robot, bus=bus), args.timeout)
    finally:
        bus.close()


def check_alive(client: Client, names: list[str]) -> int:
    """One line: whether each named service holds its liveliness token; EXIT_UNAVAILABLE if one does not."""
    with client:
        alive = client.alive(timeout=1.0)
    print(f"robot {client.robot}: " + ", ".join(f"{n} {'alive' if n in alive else 'not alive'}" for n in names))
    return EXIT_OK if set(names) <= alive else EXIT_UNAVAILABLE


def report(client: Client, timeout: float) -> int:
    """Print the stack's state; EXIT_UNAVAILABLE if a service is missing."""
    with client:
        diags = {n: client.latest(f"diag/{n}") for n in services.ALL}
        truth, pose = client.newest("sim/truth"), client.newest("pose")
        alive = client.alive(timeout=1.0)
        names = services.running(alive)  # the sim's or the real robot's
        # diag comes once a second: wait until every live service has sent one, or the timeout.
        deadline = time.monotonic() + timeout
        for n in names:
            if n in alive:
                try:
                    diags[n].wait(timeout=max(deadline - time.monotonic(), 0.0))
                except TimeoutError:
                    pass
        print(f"robot {client.robot}: {len(alive)}/{len(names)} services alive")
        print("\n".join(service_rows(names, {n: diags[n].msg for n in names}, alive)))
        print(pose_line("truth", truth.msg, None))
        print(pose_line("pose", pose.msg, truth.msg))
        try:
            st = client.query("nav/status", timeout=2.0)
            dist = f"{st.distance_remaining:.3f} m" if st.distance_remaining is not None else "-"
            print(f"nav    {st.state}  moving {st.is_moving}  goal {st.goal_id}  remaining {dist}  result {st.result or '-'}")
        except ZenavError as e:
            print(f"nav    {e}")
    if not set(names) <= alive:
        print(f"missing: {', '.join(s for s in names if s not in alive)}", file=sys.stderr)
        return EXIT_UNAVAILABLE
    return EXIT_OK
