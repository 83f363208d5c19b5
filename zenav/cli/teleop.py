"""`zenav teleop`: drive the robot from the keyboard, publishing `cmd_vel` with t = 0 ("now").

Hold an arrow key (or W A S D) to drive, space stops, q or Ctrl-C quits. With no key
for --deadman ms the command drops to zero (a key held down repeats). While no key is
held, nothing is sent, so a goal sent from elsewhere can drive; a key that drives while
a goal runs stops that goal first (`nav/stop`): the hand has the robot, not the goal.
Exit codes: 0 quit, 2 no terminal or bad arguments, 3 no router.
"""

from __future__ import annotations

import argparse
import os
import select
import sys
import termios
import time
import tty
from typing import cast

from zenav.cli.checks import Failed, fail
from zenav.cli.keymap import Drive, command, press, split_keys
from zenav.cli.main import EXIT_OK, EXIT_USAGE
from zenav.cli.session import open_bus, positive, robot_id
from zenav.common import codec, keys
from zenav.common import messages as m
from zenav.common.app import connection_args
from zenav.common.bus import ZenohBus
from zenav.common.client import Client, ZenavError
from zenav.common.contract import State

PERIOD = 0.05  # [s] a held key's command is sent this often (20 Hz, inside the motor's watchdog)
STOP_TIMEOUT = 1.0  # [s] for the navigator to answer the nav/stop of a key that drives while a goal runs
HELP = "arrows/WASD drive, space stops, q quits"


def add_arguments(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("teleop", help=f"drive from the keyboard through cmd_vel ({HELP})", description=__doc__)
    connection_args(p)
    p.add_argument("--speed", type=positive, default=0.2, help="forward speed of up/down [m/s] (default 0.2)")
    p.add_argument("--turn", type=positive, default=1.0, help="turn rate of left/right [rad/s] (default 1.0)")
    p.add_argument("--deadman", type=positive, default=500.0, help="no key for this long: command zero [ms] (default 500)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if not (sys.stdin.isatty() and sys.stdout.isatty()):
        print("zenav teleop: needs a terminal (stdin and stdout must be a TTY)", file=sys.stderr)
        return EXIT_USAGE
    try:
        robot = robot_id(args)
        bus = open_bus(args)
    except Failed as e:
        return fail("teleop", e)
    fd = sys.stdin.fileno()
    saved = termios.tcgetattr(fd)
    try:
        tty.setcbreak(fd)  # keys one by one, not echoed; Ctrl-C still interrupts
        with Client(robot, bus=bus) as client:
            drive_loop(bus, keys.key(robot, "cmd_vel"), Drive(args.speed, args.turn, args.deadman / 1000.0), fd, Override(client))
    except KeyboardInterrupt:
        pass
    finally:
        termios.tcsetattr(fd, termios.TCSADRAIN, saved)
        bus.publish(keys.key(robot, "cmd_vel"), codec.encode(m.CmdVel(t=0.0, v=0.0, omega=0.0)))
        bus.close()
        print()
    return EXIT_OK


class Override:
    """Stops the goal the navigator runs when the keys drive, so the two do not fight."""

    def __init__(self, client: Client) -> None:
        self.client, self.state = client, client.latest("nav/state")
        self.stopped = 0  # the goal id stopped last

    def take(self) -> int | None:
        """Stop the running goal, if nav/state shows one not stopped yet; its id."""
        st = self.state.msg
        if st is None or st.state == State.STOPPED or st.goal_id == self.stopped:
            return None
        self.stopped = st.goal_id
        try:
            self.client.query("nav/stop", timeout=STOP_TIMEOUT)
        except ZenavError:
            return None  # no navigator to answer: nothing drives but the keys
        return cast(int | None, st.goal_id)


def drive_loop(bus: ZenohBus, key: str, drive: Drive, fd: int, override: Override) -> None:
    """Read keys and publish their command until q: while a key drives, and once on each stop."""
    sent = (0.0, 0.0)
    print(f"teleop on {key}: {HELP}")
    while True:
        ready, _, _ = select.select([fd], [], [], PERIOD)
        now = time.monotonic()
        data = os.read(fd, 64) if ready else b""
        if ready and not data:  # the terminal is gone
            return
        for name in split_keys(data):
            if name == "quit":
                return
            drive = press(drive, name, now)
        cmd = command(drive, now)
        stopped = override.take() if cmd != (0.0, 0.0) else None
        if stopped is not None:
            print(f"\rteleop: stopped goal {stopped} to drive by hand", flush=True)
        if cmd != (0.0, 0.0) or sent != (0.0, 0.0):
            bus.publish(key, codec.encode(m.CmdVel(t=0.0, v=cmd[0], omega=cmd[1])))
            print(f"\rv {cmd[0]:+.2f} m/s  omega {cmd[1]:+.2f} rad/s   ", end="", flush=True)
        sent = cmd
