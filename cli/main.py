"""The `zenav` command: one subcommand per module of zenav.cli."""
from __future__ import annotations

import argparse
import importlib
import sys
from typing import Optional, Sequence

# Subcommand modules; each defines add_arguments(subparsers) and sets `func` on its parsers.
MODULES = ("up", "router", "status", "nav", "watch", "record", "replay", "view", "plot", "bench")

EXIT_OK, EXIT_FAILED, EXIT_USAGE, EXIT_UNAVAILABLE = 0, 1, 2, 3


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="zenav", description="Localization and navigation for a differential-drive robot over Zenoh.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in MODULES:
        importlib.import_module(f"zenav.cli.{name}").add_arguments(sub)
    return parser


def main(argv: Optional[Sequence[str]] = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        return 130
    except ImportError as e:  # recording, view, plots and bench need the `tools` extra
        print(f"zenav {args.command}: needs the optional package {e.name!r}: pip install 'zenav[tools]'", file=sys.stderr)
        return EXIT_USAGE


if __name__ == "__main__":
    sys.exit(main())
