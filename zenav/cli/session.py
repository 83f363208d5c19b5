"""How every client command reaches the robot: check the robot id, then open a session that fails fast.

Arguments are checked before any connection (a bad one is EXIT_USAGE); a router that
does not answer in CONNECT_TIMEOUT seconds is EXIT_UNAVAILABLE, one line without
Zenoh's source locations.
"""

from __future__ import annotations

import argparse
import math

import zenoh

from zenav.cli.checks import Failed, check_robot, zenoh_reason
from zenav.cli.main import EXIT_UNAVAILABLE
from zenav.common.bus import ZenohBus
from zenav.common.keys import DEFAULT_CONNECT
from zenav.robot import LEASE_TIMEOUT

CONNECT_TIMEOUT = 3.0  # [s] how long to look for the router before giving up


def robot_id(args: argparse.Namespace) -> str:
    """The robot a command talks to (--robot, $ZENAV_ROBOT, else r1); Failed(EXIT_USAGE) if it is no robot id."""
    check_robot(args.robot)
    return str(args.robot or "r1")


def open_bus(args: argparse.Namespace) -> ZenohBus:
    """A session of the router at --connect as --zenoh-mode; Failed(EXIT_UNAVAILABLE) if none answers in time.

    A command that holds its goal's lease (--wait) announces the robot library's short
    transport lease: if it freezes, the router drops its lease token and the robot stops."""
    connect = args.connect or DEFAULT_CONNECT
    lease = LEASE_TIMEOUT if getattr(args, "wait", False) else None
    try:
        return ZenohBus.open(connect, mode=args.zenoh_mode or "client", connect_timeout=CONNECT_TIMEOUT, lease=lease)
    except zenoh.ZError as e:
        raise Failed(EXIT_UNAVAILABLE, f"no Zenoh router at {connect} ({zenoh_reason(e)})") from None


def positive(text: str) -> float:
    """A finite number > 0 (argparse type: seconds, counts of seconds)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"{text!r} must be a finite number > 0")
    return value
