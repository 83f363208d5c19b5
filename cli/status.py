"""`zenav status`: services, rates, counters and the navigator's state, from any terminal."""
from __future__ import annotations

import argparse
import sys

from zenav.cli.main import EXIT_OK, EXIT_UNAVAILABLE
from zenav.cli.screen import pose_line, service_rows
from zenav.common.app import deployment_args
from zenav.common.client import Client, ClientError
from zenav.common.keys import SERVICES


def add_arguments(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("status", help="services, rates, counters and navigation state of a running stack")
    deployment_args(p)
    p.add_argument("--timeout", type=float, default=2.0, help="seconds to collect diag (default 2; diag is 1 Hz)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    try:
        client = Client(args.robot or "r1", args.connect, connect_timeout=3.0)
    except ClientError as e:
        print(f"zenav status: {e.message}", file=sys.stderr)
        return EXIT_UNAVAILABLE
    with client:
        diags = {n: client.latest(f"diag/{n}") for n in SERVICES}
        truth, pose = client.latest("sim/truth"), client.latest("pose")
        alive = client.alive(timeout=1.0)
        # diag comes once a second: wait until every live service has sent one, or the timeout.
        for n in SERVICES:
            if n in alive:
                try:
                    diags[n].wait(timeout=max(args.timeout, 0.1))
                except TimeoutError:
                    pass
        print(f"robot {client.robot}: {len(alive)}/{len(SERVICES)} services alive")
        print("\n".join(service_rows(SERVICES, {n: d.msg for n, d in diags.items()}, alive)))
        print(pose_line("truth", truth.msg, None))
        print(pose_line("pose", pose.msg, truth.msg))
        try:
            st = client.query("nav/status", timeout=2.0)
            dist = f"{st.distance_remaining:.3f} m" if st.distance_remaining is not None else "-"
            print(f"nav    {st.state}  moving {st.is_moving}  goal {st.goal_id}  remaining {dist}  result {st.result or '-'}")
        except ClientError as e:
            print(f"nav    {e}")
    if alive != set(SERVICES):
        print(f"missing: {', '.join(s for s in SERVICES if s not in alive)}", file=sys.stderr)
        return EXIT_UNAVAILABLE
    return EXIT_OK
