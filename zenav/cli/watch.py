"""`zenav watch`: a live text view of the navigator, the pose against the truth, the latest
VPS fix and every service's rates, refreshed in place until Ctrl-C."""

from __future__ import annotations

import argparse
import math
import sys
import threading
from collections import deque
from collections.abc import Callable
from typing import Any

import msgspec

from zenav import services
from zenav.cli.main import EXIT_OK, EXIT_UNAVAILABLE
from zenav.cli.nav import open_client, progress
from zenav.cli.screen import pose_line, service_rows
from zenav.common import messages as m
from zenav.common.app import deployment_args
from zenav.common.client import Client, Latest, Sampled, Unavailable
from zenav.common.track import Track

TRUTH_KEEP = 500  # truth samples kept to match a pose's t (5 s at 100 Hz)
CLEAR = "\x1b[H\x1b[2J"  # cursor home, clear screen


def add_arguments(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("watch", help="live view: nav state, pose vs truth, latest VPS fix, service rates")
    deployment_args(p)
    p.add_argument("--period", type=float, default=0.5, help="refresh period [s] (default 0.5)")
    p.add_argument("--once", action="store_true", help="listen for one period, print one view and exit")
    p.set_defaults(func=run)


class View:
    """The newest of every topic the view shows, kept by subscriptions."""

    def __init__(self, client: Client) -> None:
        self.robot = client.robot
        self.latest: dict[str, Latest | Sampled] = {
            s: client.latest(s) for s in ("nav/state", "localizer/fixes", *(f"diag/{n}" for n in services.ALL))
        }
        self.latest["pose"] = client.newest("pose")  # 100 Hz: read as the view is drawn
        self.truths: deque[Any] = deque(maxlen=TRUTH_KEEP)  # in arrival order, which is t order
        self.alive: set[str] = set()
        client.subscribe("sim/truth", self.truths.append)
        client.bus.watch_tokens(client.key("alive/*"), self._on_token)

    def _on_token(self, key: str, up: bool) -> None:
        (self.alive.add if up else self.alive.discard)(key.rsplit("/", 1)[-1])

    def text(self) -> str:
        """The whole view now."""
        pose = self.latest["pose"].msg
        diags = {n: self.latest[f"diag/{n}"].msg for n in services.running(self.alive)}
        truths = list(self.truths)
        truth = truth_at(truths, pose.t if pose else None)
        nav, fix = self.latest["nav/state"].msg, self.latest["localizer/fixes"].msg
        return render(self.robot, nav, pose, truth, fix, diags, set(self.alive))


def truth_at(truths: list[m.Truth], t: float | None) -> m.Truth | None:
    """The truth interpolated at t (the newest sample's v and omega), or the newest if t is None."""
    if not truths:
        return None
    if t is None:
        return truths[-1]
    x, y, theta = Track((s.t, s.x, s.y, s.theta) for s in truths).at(t)
    return msgspec.structs.replace(truths[-1], t=t, x=x, y=y, theta=theta)


def fix_line(fix: Any) -> str:
    """The latest VPS fix as the localizer judged it."""
    if fix is None:
        return "fix    (none yet)"
    dx, dy, dth = fix.innovation
    verdict = "accepted" if fix.accepted else f"rejected ({fix.reason})"
    return (
        f"fix    t {fix.t:8.2f} s  latency {fix.latency * 1000:4.0f} ms  innovation {math.hypot(dx, dy) * 100:5.2f} cm "
        f"{math.degrees(dth):+5.1f} deg  d2 {fix.mahalanobis_d2:5.1f}  replayed {fix.replay_depth}  {verdict}"
    )


def render(robot: str, nav: Any, pose: Any, truth: Any, fix: Any, diags: dict[str, Any], alive: set[str]) -> str:
    """The view as text: navigator, pose vs truth at the pose's t, fix, services."""
    t = f"t {pose.t:8.2f} s" if pose is not None else "t -"
    lines = [f"zenav watch  robot {robot}  {t}   (Ctrl-C to quit)", ""]
    lines.append("nav    (no nav/state yet)" if nav is None else "nav    " + progress(nav).rstrip())
    if nav is not None and nav.result is not None:
        lines.append(f"       goal {nav.goal_id} {nav.result}{': ' + nav.message if nav.message else ''}")
    if nav is not None and nav.cross_track_error is not None:
        heading = math.degrees(nav.heading_error or 0.0)
        lines.append(f"       cross-track {nav.cross_track_error * 100:+.2f} cm  heading error {heading:+.1f} deg")
    lines += ["", pose_line("truth", truth, None), pose_line("pose", pose, truth), fix_line(fix), ""]
    lines += service_rows(list(diags), diags, alive)
    return "\n".join(lines)


def run(args: argparse.Namespace, connect: Callable[[argparse.Namespace], Client] = open_client) -> int:
    """Refresh the view every period until Ctrl-C (or once)."""
    try:
        client = connect(args)
    except Unavailable as e:
        print(f"zenav watch: {e}", file=sys.stderr)
        return EXIT_UNAVAILABLE
    tick = threading.Event()  # never set: waits pace the refresh
    tty = sys.stdout.isatty()
    with client:
        view = View(client)
        try:
            while True:
                tick.wait(args.period)
                print((CLEAR if tty else "") + view.text(), flush=True)
                if args.once:
                    return EXIT_OK
                if not tty:
                    print()
        except KeyboardInterrupt:
            return EXIT_OK
