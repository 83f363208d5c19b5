"""`zenav up`: a router and every service as its own process, with a live status screen."""
from __future__ import annotations

import argparse
import os
import sys
import threading
import time
from pathlib import Path

import zenoh

from zenav import services
from zenav.cli.router import DEFAULT_LISTEN, open_router
from zenav.cli.screen import render
from zenav.cli.supervisor import Supervisor
from zenav.common import messages as m
from zenav.common.app import deployment_args, settings_from_args, stop_on_signals
from zenav.common.bus import ZenohBus, zenoh_config
from zenav.common.client import Client, ClientError
from zenav.common.config import ConfigError
from zenav.common.keys import SERVICES

STOP_ORDER = ("navigator", "localizer", "vps", "odometry", "motor", "sim")  # wheels stop before the world
DEMO_SQUARE = ((1.0, 0.0), (1.0, 1.0), (0.0, 1.0), (0.0, 0.0))  # [m] map frame


def add_arguments(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("up", help="start a router and every service, show live status; Ctrl-C stops all")
    deployment_args(p)
    p.add_argument("--listen", default=DEFAULT_LISTEN, help=f"endpoint of the embedded router (default {DEFAULT_LISTEN})")
    p.add_argument("--services", default=",".join(SERVICES), help="comma-separated subset to run (default: all)")
    p.add_argument("--demo", action="store_true", help="drive a 1 m square in a loop through the navigator")
    p.add_argument("--duration", type=float, help="stop by itself after this many wall seconds")
    p.add_argument("--log-dir", type=Path, help="service logs (default: $XDG_STATE_HOME/zenav/logs)")
    p.add_argument("--wait-timeout", type=float, default=60.0, help="seconds to wait for every service (default 60)")
    p.set_defaults(func=run)


def default_log_dir() -> Path:
    base = os.environ.get("XDG_STATE_HOME") or os.path.join(os.path.expanduser("~"), ".local", "state")
    return Path(base) / "zenav" / "logs"


def child_args(args: argparse.Namespace, endpoint: str) -> list[str]:
    """What every service process is started with.

    With the embedded router everything runs on this host, so the services are Zenoh
    peers (they also link directly: lower latency and router CPU, see README) unless
    --zenoh-mode says otherwise; with --connect they stay clients of that router.
    """
    mode = args.zenoh_mode or ("client" if args.connect else "peer")
    out = ["--connect", endpoint, "--zenoh-mode", mode]
    for flag in ("robot", "config", "scenario", "seed"):  # --connect is the endpoint above
        value = getattr(args, flag)
        if value is not None:
            out += [f"--{flag}", str(value)]
    for item in args.set:
        out += ["--set", item]
    return out


def navigator_ready(client: Client, done: threading.Event, say=lambda line: None) -> bool:
    """Wait until the navigator would take a goal: a fresh, certain pose (False if stopped first).

    Says why it waits whenever the reason changes (no pose yet, too uncertain...).
    """
    pose, why = client.latest("pose"), ""
    while not done.is_set():
        try:
            pose.wait(timeout=1.0)
            not_ready = client.query("nav/status", timeout=2.0).not_ready
            if not not_ready:
                return True
            if not_ready.split(":")[0] != why.split(":")[0]:
                say(f"demo: waiting for the navigator: {not_ready}")
            why = not_ready
        except (TimeoutError, ClientError):
            pass
        done.wait(0.2)  # poses flow at 100 Hz: ask again shortly
    return False


def demo_loop(client: Client, done: threading.Event, say) -> None:
    """Drive the square corner by corner until `done`; each goal waits for its end."""
    if not navigator_ready(client, done, say):
        return
    say("demo: driving a 1 m square, corner by corner")
    i = 0
    while not done.is_set():
        x, y = DEMO_SQUARE[i % len(DEMO_SQUARE)]
        try:
            rep = client.query("nav/move_to_point", {"x": x, "y": y, "wait": True}, timeout=60.0)
            if rep.result != "succeeded":
                say(f"demo goal ({x}, {y}) {rep.result}: {rep.message}")
                done.wait(1.0)
        except ClientError as e:
            say(f"demo: {e}")
            done.wait(1.0)
        i += 1


def run(args: argparse.Namespace) -> int:
    names = [n.strip() for n in args.services.split(",") if n.strip()]
    unknown = set(names) - set(SERVICES)
    if unknown:
        print(f"zenav up: unknown service(s): {', '.join(sorted(unknown))}", file=sys.stderr)
        return 2
    try:
        settings = settings_from_args(args)  # fail fast here rather than in six children
        for name in names:
            cls = services.load(name)
            if cls.config_type is not None:
                settings.section(name, cls.config_type)
    except ConfigError as e:
        print(f"zenav up: {e}", file=sys.stderr)
        return 2
    robot = settings.robot_id
    # --connect: join a router that runs elsewhere; otherwise embed one.
    endpoint = args.connect or args.listen
    session = zenoh.open(zenoh_config("client", connect=args.connect)) if args.connect else open_router(args.listen)
    log_dir = args.log_dir or default_log_dir()
    events: list[str] = []
    tty = sys.stdout.isatty()

    def say(line: str) -> None:
        stamped = f"{time.strftime('%H:%M:%S')} {line}"
        events.append(stamped)
        del events[:-5]
        if not tty:
            print(stamped, flush=True)

    sup = Supervisor.for_services(names, child_args(args, endpoint), log_dir, events=say)
    client = Client(robot, bus=ZenohBus(session))
    done = stop_on_signals()
    say(f"{'router at' if args.connect else 'router on'} {endpoint}; starting {', '.join(names)} (logs in {log_dir})")
    t0 = time.monotonic()
    sup.start_all()
    try:
        if _wait_alive(client, sup, names, args.wait_timeout, done) is None:
            return 1
        say(f"all {len(names)} services alive in {time.monotonic() - t0:.1f} s")
        alive: set[str] = set()
        client.bus.watch_tokens(client.key("alive/*"), lambda key, up: (alive.add if up else alive.discard)(key.rsplit("/", 1)[-1]))
        topics = {s: client.latest(s) for s in ("sim/truth", "odom", "pose", "nav/state")}
        diags = {n: client.latest(f"diag/{n}") for n in names}
        if args.demo:
            threading.Thread(target=demo_loop, args=(client, done, say), daemon=True).start()
        deadline = None if args.duration is None else time.monotonic() + args.duration
        last_line = last_screen = 0.0
        while not done.is_set() and (deadline is None or time.monotonic() < deadline):
            sup.poll()
            if tty and time.monotonic() - last_screen >= 0.5:
                screen = render(robot, endpoint, settings.deployment.scenario, sup, topics, diags, set(alive), events)
                sys.stdout.write("\x1b[H\x1b[2J" + screen + "\n")
                sys.stdout.flush()
                last_screen = time.monotonic()
            elif not tty and time.monotonic() - last_line >= 5.0:
                print(_summary(topics), flush=True)
                last_line = time.monotonic()
            done.wait(0.2)
    finally:
        done.set()
        _shutdown(client, sup, say)
        session.close()
    return 0


def _wait_alive(client: Client, sup: Supervisor, names: list[str], timeout: float, done: threading.Event):
    deadline = time.monotonic() + timeout
    while not done.is_set():
        sup.poll()
        try:
            return client.wait_alive(names, timeout=min(1.0, max(deadline - time.monotonic(), 0.01)))
        except TimeoutError as e:
            if time.monotonic() >= deadline:
                print(f"zenav up: {e}; see the logs in {sup.children[names[0]].log.parent}", file=sys.stderr)
                return None
    return None


def _summary(topics: dict) -> str:
    truth, pose, nav = topics["sim/truth"].msg, topics["pose"].msg, topics["nav/state"].msg
    parts = []
    if truth is not None:
        parts.append(f"t={truth.t:7.2f}s truth=({truth.x:+.3f},{truth.y:+.3f})")
    if pose is not None:
        parts.append(f"pose=({pose.x:+.3f},{pose.y:+.3f})")
    if nav is not None:
        parts.append(nav.state)
    return "  ".join(parts) or "waiting for data"


def _shutdown(client: Client, sup: Supervisor, say) -> None:
    """Navigator first, then a zero command, then the motor (zero wheels), the world last."""
    say("stopping: wheels to zero first")

    def after(name: str) -> None:
        if name == "navigator":
            client.publish("cmd_vel", m.CmdVel(t=0.0, v=0.0, omega=0.0))

    sup.stop(STOP_ORDER, between=after)
    say("all services stopped")
