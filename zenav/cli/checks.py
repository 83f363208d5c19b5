"""What the tool commands (record, view, replay, plot) check before their work.

Arguments, config and input files, before any connection (cli/session.py then opens
the session): a check that fails is one line on stderr and an exit code, EXIT_USAGE
for bad arguments, config or input files (EXIT_UNAVAILABLE for no router).
"""

from __future__ import annotations

import argparse
import os
import re
import sys

import zenoh

from zenav.cli.main import EXIT_USAGE
from zenav.common import keys
from zenav.common.app import settings_from_args
from zenav.common.config import ConfigError, Deployment

_RUST_LOCATION = re.compile(r"\s+at \S+\.rs:\d+\.?$")  # Zenoh's errors end with the Rust source line


class Failed(Exception):
    """A command cannot start: `message` is its one line, `code` its exit code."""

    def __init__(self, code: int, message: str) -> None:
        super().__init__(message)
        self.code, self.message = code, message


def zenoh_reason(e: zenoh.ZError) -> str:
    """A Zenoh error as a user reads it: without the Rust source location."""
    return _RUST_LOCATION.sub("", str(e)).rstrip(".")


def check_robot(robot: str | None, option: str = "--robot") -> None:
    """Failed(EXIT_USAGE) unless `robot` is None or a valid robot id."""
    if robot is not None:
        try:
            keys.check_robot_id(robot)
        except ValueError as e:
            raise Failed(EXIT_USAGE, f"{option}: {e}") from None


def deployment(args: argparse.Namespace) -> Deployment:
    """The deployment settings (--robot, --connect, --config, --set, env); Failed(EXIT_USAGE) if invalid."""
    check_robot(args.robot)
    try:
        return settings_from_args(args).deployment
    except ConfigError as e:
        raise Failed(EXIT_USAGE, str(e)) from None


def check_recording(path: str) -> bool:
    """Whether the recording at `path` was finished; Failed(EXIT_USAGE) if it is no MCAP recording."""
    from zenav.tools import mcap_format as fmt  # optional dependency (mcap)

    if not os.path.exists(path):
        part = path + fmt.PART
        hint = f" ({part} is there: a recording not closed cleanly; pass that name)" if os.path.exists(part) else ""
        raise Failed(EXIT_USAGE, f"no such file: {path}{hint}")
    try:
        return fmt.finished(path)
    except (OSError, fmt.BadRecording) as e:
        raise Failed(EXIT_USAGE, str(e)) from None


def note_unfinished(command: str, path: str) -> None:
    """Tell that a recording is read although its recorder did not finish it."""
    print(f"zenav {command}: {path} was not closed cleanly (its recorder died): reading it up to its last complete chunk", file=sys.stderr)


def fail(command: str, failed: Failed) -> int:
    """Print the one line of a command that cannot start; its exit code."""
    print(f"zenav {command}: {failed.message}", file=sys.stderr)
    return failed.code
