"""`zenav goto | turn | face | straight | path | stop`: drive the robot through the navigator.

Without --wait a command returns once the navigator accepts the goal. With --wait it
shows a progress line until the goal ends, and holds a liveliness token as the goal's
lease, so Ctrl-C (or a lost connection) cancels the goal and stops the robot.
Exit codes: 0 accepted or succeeded, 1 cancelled or aborted, 2 bad arguments,
3 no router, navigator down or unavailable (e.g. no pose yet).
"""
from __future__ import annotations

import argparse
import math
import os
import sys
import threading
import time
import uuid
from typing import Any, Callable, Optional, TextIO

from zenav.cli.main import EXIT_FAILED, EXIT_OK, EXIT_UNAVAILABLE, EXIT_USAGE
from zenav.common.app import deployment_args
from zenav.common.client import Client, ClientError

CONNECT_TIMEOUT = 3.0  # [s] how long to look for the router before giving up
QUERY_TIMEOUT = 5.0  # [s] a goal without --wait is answered at once
WAIT_TIMEOUT = 3600.0  # [s] default --timeout: the navigator ends stuck goals itself
EXIT_CODES = {"invalid_argument": EXIT_USAGE, "unavailable": EXIT_UNAVAILABLE}  # other errors: EXIT_FAILED


def open_client(args: argparse.Namespace) -> Client:
    """A client of the robot's stack; ClientError `unavailable` if no router answers."""
    return Client(args.robot or "r1", args.connect, connect_timeout=CONNECT_TIMEOUT)


def point(text: str) -> list[float]:
    """`X,Y` -> [x, y] (argparse type)."""
    try:
        x, y = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not X,Y (two numbers, e.g. 1.5,-0.2)") from None
    if not all(math.isfinite(v) for v in (x, y)):
        raise argparse.ArgumentTypeError(f"{text!r}: coordinates must be finite")
    return [x, y]


def finite(text: str) -> float:
    """A finite number (argparse type)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"{text!r} is not finite")
    return value


def add_arguments(sub: argparse._SubParsersAction) -> None:
    common = argparse.ArgumentParser(add_help=False)
    deployment_args(common)
    common.add_argument("--wait", action="store_true", help="wait for the goal to end, with a progress line; Ctrl-C stops the robot")
    common.add_argument(
        "--timeout", type=finite, help=f"seconds to wait for the reply (default {QUERY_TIMEOUT:g}; with --wait {WAIT_TIMEOUT:g})"
    )
    move = argparse.ArgumentParser(add_help=False)
    move.add_argument("--speed", type=finite, help="forward speed limit [m/s] (default and limit: navigator config)")
    move.add_argument("--tolerance", type=finite, help="position tolerance [m] (default: navigator config)")
    turn = argparse.ArgumentParser(add_help=False)
    turn.add_argument("--speed", type=finite, help="turn rate [rad/s, deg/s with --deg]")
    turn.add_argument("--tolerance", type=finite, help="heading tolerance [rad, deg with --deg]")
    turn.add_argument("--deg", action="store_true", help="angles in degrees instead of radians")

    p = sub.add_parser("goto", parents=[common, move], help="move to a point (map frame, metres)")
    p.add_argument("x", type=finite, help="[m]")
    p.add_argument("y", type=finite, help="[m]")
    p.set_defaults(func=run, query="nav/move_to_point")
    p = sub.add_parser("turn", parents=[common, turn], help="turn in place to a heading (radians, CCW from +x; --deg for degrees)")
    p.add_argument("heading", type=finite, help="[rad] (degrees with --deg)")
    p.set_defaults(func=run, query="nav/turn_to_heading")
    p = sub.add_parser("face", parents=[common, turn], help="turn in place to face a point (map frame, metres)")
    p.add_argument("x", type=finite, help="[m]")
    p.add_argument("y", type=finite, help="[m]")
    p.set_defaults(func=run, query="nav/turn_to_point")
    p = sub.add_parser("straight", parents=[common], help="drive straight on the current heading, holding the line")
    p.add_argument("speed", type=finite, help="[m/s], negative to reverse")
    p.add_argument("--distance", type=finite, help="stop after this far [m] (default: until `zenav stop`)")
    p.set_defaults(func=run, query="nav/move_straight")
    path_help = "follow points in order: zenav path 1,0 1,1 (put -- before a first point with a negative x)"
    p = sub.add_parser("path", parents=[common, move], help=path_help)
    p.add_argument("points", type=point, nargs="+", metavar="X,Y", help="[m]")
    p.set_defaults(func=run, query="nav/follow_path")
    p = sub.add_parser("stop", parents=[common], help="cancel the goal and stop the robot now")
    p.set_defaults(func=run, query="nav/stop")
    p = sub.add_parser("set-pose", parents=[common], help="tell the localizer where the robot is (map frame; a robot without a camera)")
    p.add_argument("x", type=finite, help="[m]")
    p.add_argument("y", type=finite, help="[m]")
    p.add_argument("theta", type=finite, nargs="?", help="[rad] (degrees with --deg; default: keep the heading)")
    p.add_argument("--deg", action="store_true", help="theta in degrees")
    p.set_defaults(func=run, query="localizer/set_pose")


def request(args: argparse.Namespace) -> dict[str, Any]:
    """The query payload of a parsed command (contract units: metres, radians)."""
    scale = math.radians(1.0) if getattr(args, "deg", False) else 1.0
    fields: dict[str, Any] = {}
    if args.query in ("nav/move_to_point", "nav/turn_to_point"):
        fields = {"x": args.x, "y": args.y}
    elif args.query == "nav/turn_to_heading":
        fields = {"heading": args.heading * scale}
    elif args.query == "nav/move_straight":
        fields = {"speed": args.speed, "distance": args.distance}
    elif args.query == "nav/follow_path":
        fields = {"points": args.points}
    elif args.query == "localizer/set_pose":
        return {k: v for k, v in {"x": args.x, "y": args.y, "theta": None if args.theta is None else args.theta * scale}.items()
                if v is not None}
    if args.query not in ("nav/move_straight", "nav/stop"):
        fields["speed"] = None if args.speed is None else args.speed * scale
        fields["tolerance"] = None if args.tolerance is None else args.tolerance * scale
    return {k: v for k, v in fields.items() if v is not None}


def run(args: argparse.Namespace, connect: Callable[[argparse.Namespace], Client] = open_client) -> int:
    """Send the command; the exit code says how it went."""
    try:
        with connect(args) as client:
            if args.query == "nav/stop":
                rep = client.query("nav/stop", timeout=args.timeout or QUERY_TIMEOUT)
                print(f"stopped ({rep.state})")
                return EXIT_OK
            if args.query == "localizer/set_pose":
                p = client.query(args.query, request(args), timeout=args.timeout or QUERY_TIMEOUT)
                print(f"pose set: x {p.x:+.3f} y {p.y:+.3f} th {math.degrees(p.theta):+.1f} deg")
                return EXIT_OK
            if args.wait:
                return wait(client, args, request(args))
            rep = client.query(args.query, request(args), timeout=args.timeout or QUERY_TIMEOUT)
            print(f"goal {rep.goal_id} {rep.state}{speed_text(args, rep.speed)}")
            return EXIT_OK
    except ClientError as e:
        print(f"zenav {args.command}: {e}", file=sys.stderr)
        return EXIT_CODES.get(e.code, EXIT_FAILED)


def wait(client: Client, args: argparse.Namespace, req: dict[str, Any], out: TextIO = sys.stderr) -> int:
    """Send the goal with wait and a lease, show progress until its reply, map the result."""
    lease = client.key(f"lease/cli-{os.getpid()}-{uuid.uuid4().hex[:8]}")
    token = client.bus.token(lease)  # withdrawn when this process or its session ends
    state = client.latest("nav/state")
    done: dict[str, Any] = {}

    def ask() -> None:
        try:
            done["reply"] = client.query(args.query, {**req, "wait": True, "lease": lease}, timeout=args.timeout or WAIT_TIMEOUT)
        except ClientError as e:
            done["error"] = e

    asker = threading.Thread(target=ask, name="zenav-goal", daemon=True)
    asker.start()
    tty, shown = out.isatty(), 0.0
    while asker.is_alive():
        asker.join(0.2)
        now = time.monotonic()
        if state.msg is not None and (tty or now - shown >= 1.0):
            print(progress(state.msg), end="\r" if tty else "\n", file=out, flush=True)
            shown = now
    if tty and shown:
        print(file=out)
    token.undeclare()
    if "error" in done:
        raise done["error"]
    rep = done["reply"]
    pose = rep.pose
    where = f" at x {pose.x:+.3f} y {pose.y:+.3f} th {math.degrees(pose.theta):+.1f} deg" if pose else ""
    print(f"goal {rep.goal_id} {rep.result}{': ' + rep.message if rep.message else ''}{where}")
    return EXIT_OK if rep.result == "succeeded" else EXIT_FAILED


def speed_text(args: argparse.Namespace, speed: Optional[float]) -> str:
    """The speed the navigator used, in the command's units."""
    if speed is None:
        return ""
    if args.query in ("nav/turn_to_heading", "nav/turn_to_point"):
        return f" at {math.degrees(speed):.0f} deg/s" if args.deg else f" at {speed:.2f} rad/s"
    return f" at {speed:.2f} m/s"


def progress(st: Any) -> str:
    """One line of nav/state: state, goal, distance remaining, ETA, elapsed."""
    unit = "rad" if st.state == "TURNING_TO_HEADING" else "m"
    dist = "-" if st.distance_remaining is None else f"{st.distance_remaining:.3f} {unit}"
    eta = "-" if st.eta is None else f"{st.eta:.1f} s"
    point = "" if st.next_point is None else f"  next point {st.next_point}"
    return f"{st.state:<18} goal {st.goal_id}  remaining {dist}  eta {eta}  elapsed {st.elapsed:.1f} s{point}   "
