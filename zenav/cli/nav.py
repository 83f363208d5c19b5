"""`zenav goto | turn | swing | face | straight | path | stop | set-pose | drive`: drive the robot through the navigator.

`zenav drive` alone goes round it: open loop on `cmd_vel` for a time (squaring up against a wall).

Without --wait a command returns once the navigator accepts the goal. With --wait it
shows a progress line until the goal ends, and holds a liveliness token as the goal's
lease, so Ctrl-C (or a lost connection) cancels the goal and stops the robot.
Exit codes: 0 accepted or succeeded, 1 cancelled or aborted, 2 bad arguments
(checked before connecting: a heading beyond 2 pi without --deg is one),
3 no router, navigator down or unavailable (e.g. no pose yet), or the goal
not ended within --wait's --timeout.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager, contextmanager
from typing import Any, TextIO

from zenav.cli.checks import Failed, fail
from zenav.cli.main import EXIT_FAILED, EXIT_OK, EXIT_UNAVAILABLE, EXIT_USAGE
from zenav.cli.session import CONNECT_TIMEOUT, open_bus, positive, robot_id
from zenav.common.app import connection_args
from zenav.common.client import Client
from zenav.common.contract import ErrorCode, State
from zenav.common.goalschema import GOALS
from zenav.robot import Goal, Robot, ZenavError

QUERY_TIMEOUT = 5.0  # [s] a goal is answered when it starts
WAIT_TIMEOUT = 3600.0  # [s] default --timeout with --wait: the navigator ends stuck goals itself
MAX_RADIANS = 2 * math.pi  # [rad] a larger angle without --deg is taken for degrees given by mistake
DIRECTIONS = GOALS["turn_to_heading"].field("direction").choices  # a turn's --direction
EXIT_CODES: dict[str, int] = {ErrorCode.INVALID_ARGUMENT: EXIT_USAGE, ErrorCode.UNAVAILABLE: EXIT_UNAVAILABLE}  # other errors: EXIT_FAILED


def open_client(args: argparse.Namespace) -> Client:
    """A client of the robot's stack (for `zenav watch`); Unavailable if no router answers."""
    return Client(args.robot or "r1", args.connect, connect_timeout=CONNECT_TIMEOUT)


@contextmanager
def open_robot(args: argparse.Namespace) -> Iterator[Robot]:
    """The robot, holding a lease only with --wait (a goal without it outlives the command); Failed if no router answers."""
    wait = getattr(args, "wait", False)
    timeout = QUERY_TIMEOUT if wait else args.timeout or QUERY_TIMEOUT
    robot = robot_id(args)
    bus = open_bus(args)
    try:
        with Robot(robot, mode=args.zenoh_mode, lease=wait, timeout=timeout, bus=bus) as bot:
            yield bot
    finally:
        bus.close()


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


def check_angle(name: str, value: float | None, deg: bool) -> str | None:
    """Why an angle in radians (no --deg) looks like degrees: outside [-2 pi, 2 pi]; None if it does not."""
    if value is None or deg or abs(value) <= MAX_RADIANS:
        return None
    return f"{name} {value:g} rad is outside [-2 pi, 2 pi]: for degrees add --deg"


def add_arguments(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    common = argparse.ArgumentParser(add_help=False)
    connection_args(common)
    common.add_argument("--timeout", type=positive, help=f"seconds to wait for the reply (default {QUERY_TIMEOUT:g})")
    goal = argparse.ArgumentParser(add_help=False)
    connection_args(goal)
    goal.add_argument("--wait", action="store_true", help="wait for the goal to end, with a progress line; Ctrl-C stops the robot")
    goal.add_argument(
        "--timeout",
        type=positive,
        help=f"seconds to wait for the reply (default {QUERY_TIMEOUT:g}); with --wait, for the goal's end ({WAIT_TIMEOUT:g})",
    )
    move = argparse.ArgumentParser(add_help=False)
    move.add_argument("--speed", type=finite, help="forward speed limit [m/s] (default and limit: navigator config)")
    move.add_argument("--tolerance", type=finite, help="position tolerance [m] (default: navigator config)")
    turn = argparse.ArgumentParser(add_help=False)
    turn.add_argument("--speed", type=finite, help="turn rate [rad/s, deg/s with --deg]")
    turn.add_argument("--tolerance", type=finite, help="heading tolerance [rad, deg with --deg]")
    turn.add_argument("--deg", action="store_true", help="angles in degrees instead of radians")
    turn.add_argument("--direction", choices=DIRECTIONS, default="auto", help="cw / ccw: that way round (default: the shorter way)")

    back = argparse.ArgumentParser(add_help=False)
    back.add_argument("--backwards", action="store_true", help="the robot's back leads (the request's forwards = false)")

    p = sub.add_parser("goto", parents=[goal, move, back], help="move to a point (map frame, metres)")
    p.add_argument("x", type=finite, help="[m]")
    p.add_argument("y", type=finite, help="[m]")
    p.set_defaults(func=run, query="nav/move_to_point")
    p = sub.add_parser("turn", parents=[goal, turn], help="turn in place to a heading (radians, CCW from +x; --deg for degrees)")
    p.add_argument("heading", type=finite, help="[rad] in [-2 pi, 2 pi] (degrees with --deg)")
    p.set_defaults(func=run, query="nav/turn_to_heading")
    p = sub.add_parser("swing", parents=[goal, turn], help="turn to a heading about one wheel, which stays still (a swing turn)")
    p.add_argument("heading", type=finite, help="[rad] in [-2 pi, 2 pi] (degrees with --deg)")
    p.add_argument("side", choices=GOALS["swing_to_heading"].field("side").choices, help="the wheel that stays still")
    p.set_defaults(func=run, query="nav/swing_to_heading")
    p = sub.add_parser("face", parents=[goal, turn, back], help="turn in place to face a point, or the back to it with --backwards")
    p.add_argument("x", type=finite, help="[m]")
    p.add_argument("y", type=finite, help="[m]")
    p.set_defaults(func=run, query="nav/turn_to_point")
    p = sub.add_parser("straight", parents=[goal], help="drive straight on the current heading, holding the line")
    p.add_argument("speed", type=finite, help="[m/s], negative to reverse")
    p.add_argument("--distance", type=finite, help="stop after this far [m] (default: until `zenav stop`)")
    p.set_defaults(func=run, query="nav/move_straight")
    path_help = "follow points in order: zenav path 1,0 1,1 (put -- before a first point with a negative x)"
    p = sub.add_parser("path", parents=[goal, move, back], help=path_help)
    p.add_argument("points", type=point, nargs="+", metavar="X,Y", help="[m]")
    p.set_defaults(func=run, query="nav/follow_path")
    p = sub.add_parser("stop", parents=[common], help="cancel the goal and stop the robot now")
    p.set_defaults(func=run, query="nav/stop")
    p = sub.add_parser("set-pose", parents=[common], help="tell the localizer where the robot is (map frame; a robot without a camera)")
    p.add_argument("x", type=finite, help="[m]")
    p.add_argument("y", type=finite, help="[m]")
    p.add_argument("theta", type=finite, nargs="?", help="[rad] in [-2 pi, 2 pi] (degrees with --deg; default: keep the heading)")
    p.add_argument("--deg", action="store_true", help="theta in degrees")
    p.set_defaults(func=run, query="localizer/set_pose")
    p = sub.add_parser(
        "drive", parents=[common], help="drive open loop on cmd_vel for a time, then stop (square up: zenav drive -0.1 --for 1)"
    )
    p.add_argument("v", type=finite, help="[m/s], negative to reverse")
    p.add_argument("omega", type=finite, nargs="?", default=0.0, help="[rad/s] CCW (default 0)")
    p.add_argument(
        "--for", dest="seconds", type=positive, required=True, metavar="SECONDS", help="how long [s]; a running goal is stopped first"
    )
    p.set_defaults(func=run, query="cmd_vel")


# Each goal command's goal (common/goalschema.py), and its options named otherwise than the goal's fields
# (a test holds every other option equal to a field of its goal).
COMMANDS = {
    "goto": "move_to_point",
    "turn": "turn_to_heading",
    "swing": "swing_to_heading",
    "face": "turn_to_point",
    "straight": "move_straight",
    "path": "follow_path",
}
RENAMED = {"backwards": "forwards"}  # --backwards sends forwards = false
OWN = ("wait", "timeout", "deg")  # the command's own options, not the goal's (--timeout: how long the command waits)


def send(bot: Robot, args: argparse.Namespace) -> Goal:
    """Send the goal of a parsed command (contract units: metres, radians)."""
    scale = math.radians(1.0) if getattr(args, "deg", False) else 1.0
    if args.query == "nav/move_straight":
        return bot.move_straight(args.speed, distance=args.distance)
    speed = None if args.speed is None else args.speed * scale
    tolerance = None if args.tolerance is None else args.tolerance * scale
    if args.query == "nav/turn_to_heading":
        return bot.turn_to_heading(args.heading * scale, speed=speed, tolerance=tolerance, direction=args.direction)
    if args.query == "nav/swing_to_heading":
        return bot.swing_to_heading(args.heading * scale, args.side, speed=speed, tolerance=tolerance, direction=args.direction)
    forwards = not args.backwards
    if args.query == "nav/move_to_point":
        return bot.move_to_point(args.x, args.y, speed=speed, tolerance=tolerance, forwards=forwards)
    if args.query == "nav/turn_to_point":
        return bot.turn_to_point(args.x, args.y, speed=speed, tolerance=tolerance, forwards=forwards, direction=args.direction)
    return bot.follow_path(args.points, speed=speed, tolerance=tolerance, forwards=forwards)


def run(args: argparse.Namespace, connect: Callable[[argparse.Namespace], AbstractContextManager[Robot]] = open_robot) -> int:
    """Send the command; the exit code says how it went."""
    deg = getattr(args, "deg", False)
    wrong = check_angle("heading", getattr(args, "heading", None), deg) or check_angle("theta", getattr(args, "theta", None), deg)
    if wrong:
        print(f"zenav {args.command}: {wrong}", file=sys.stderr)
        return EXIT_USAGE
    try:
        with connect(args) as bot:
            if args.query == "nav/stop":
                print(f"stopped ({bot.stop()})")
                return EXIT_OK
            if args.query == "cmd_vel":
                bot.drive(args.v, args.omega, args.seconds)
                print(f"drove at v {args.v:+.2f} m/s, omega {args.omega:+.2f} rad/s for {args.seconds:g} s, then stopped")
                return EXIT_OK
            if args.query == "localizer/set_pose":
                theta = None if args.theta is None else args.theta * (math.radians(1.0) if args.deg else 1.0)
                p = bot.set_pose(args.x, args.y, theta)
                print(f"pose set: x {p.x:+.3f} y {p.y:+.3f} th {math.degrees(p.theta):+.1f} deg")
                return EXIT_OK
            goal = send(bot, args)
            if not args.wait:
                print(f"goal {goal.id} {goal.reply.state}{speed_text(args, goal.reply.speed)}")
                return EXIT_OK
            return wait(goal, args.timeout or WAIT_TIMEOUT)
    except Failed as e:
        return fail(args.command, e)
    except ZenavError as e:
        print(f"zenav {args.command}: {e}", file=sys.stderr)
        return EXIT_CODES.get(e.code, EXIT_FAILED)
    except TimeoutError as e:  # the robot stops: its lease goes with the session
        print(f"zenav {args.command}: {e}", file=sys.stderr)
        return EXIT_UNAVAILABLE


def wait(goal: Goal, timeout: float, out: TextIO | None = None) -> int:
    """Show progress (on stderr) until the goal ends (TimeoutError after `timeout` s), then its result."""
    out = out or sys.stderr
    tty, shown = out.isatty(), 0.0
    for st in goal.updates(timeout):
        now = time.monotonic()
        if tty or now - shown >= 1.0:
            print(progress(st), end="\r" if tty else "\n", file=out, flush=True)
            shown = now
    if tty and shown:
        print(file=out)
    res = goal.wait(0.0)
    print(res)
    return EXIT_OK if res.succeeded else EXIT_FAILED


def speed_text(args: argparse.Namespace, speed: float | None) -> str:
    """The speed the navigator used, in the command's units."""
    if speed is None:
        return ""
    if args.query in ("nav/turn_to_heading", "nav/turn_to_point", "nav/swing_to_heading"):
        return f" at {math.degrees(speed):.0f} deg/s" if args.deg else f" at {speed:.2f} rad/s"
    return f" at {speed:.2f} m/s"


def progress(st: Any) -> str:
    """One line of nav/state: state, goal, distance remaining, ETA, elapsed."""
    unit = "rad" if st.state == State.TURNING_TO_HEADING else "m"
    dist = "-" if st.distance_remaining is None else f"{st.distance_remaining:.3f} {unit}"
    eta = "-" if st.eta is None else f"{st.eta:.1f} s"
    point = "" if st.next_point is None else f"  next point {st.next_point}"
    return f"{st.state:<18} goal {st.goal_id}  remaining {dist}  eta {eta}  elapsed {st.elapsed:.1f} s{point}   "
