"""`zenav bench`: measure accuracy, latency, cost and simulation speed; write the report."""

from __future__ import annotations

import argparse
import dataclasses
import logging
import sys
from pathlib import Path

from zenav.cli.main import EXIT_OK
from zenav.common import extras

# The bench's sections (bench/plan.py SECTIONS; a test keeps them equal): named here so
# that building the parser imports none of the bench's optional packages.
SECTIONS = ("latency", "cost", "speed", "accuracy", "navigation", "settle", "planning", "camera", "peers", "profile", "fleet")
DEFAULT_OUT = Path("bench-report")  # a scratch directory: the committed report is written with --out docs/bench


def add_arguments(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("bench", help="measure accuracy, latency, cost and simulation speed; write a markdown report with plots")
    p.add_argument("--quick", action="store_true", help="a short run for CI (under 2 minutes): fewer seeds, modes and windows")
    p.add_argument("--out", type=Path, default=DEFAULT_OUT, help=f"report directory (default {DEFAULT_OUT}/)")
    p.add_argument("--only", action="append", choices=SECTIONS, help="measure only this section (repeatable)")
    p.add_argument("--rtf", type=float, help="most the accuracy runs may use (default 3; the speed study may lower it)")
    p.add_argument("-v", "--verbose", action="store_true", help="show the in-process services' warnings")
    p.set_defaults(func=run)


def command_line(args: argparse.Namespace) -> str:
    """The command as it would be typed, for the report."""
    parts = ["zenav bench"] + (["--quick"] if args.quick else []) + [f"--only {s}" for s in args.only or []]
    parts += [f"--rtf {args.rtf:g}"] if args.rtf is not None else []
    return " ".join(parts + [f"--out {args.out}"])


def run(args: argparse.Namespace) -> int:
    for module in ("matplotlib", "mcap", "cv2", "serial"):  # what the sections import or run: zenav[bench] has them all
        extras.check(module, "the benchmark", extra="bench")
    from zenav.bench import plan, report
    from zenav.bench.run import run as measure

    logging.basicConfig(level=logging.WARNING, format="%(name)s %(levelname)s %(message)s", stream=sys.stderr)
    if not args.verbose:  # the stacks run in this process for accuracy: their warnings would flood the terminal
        logging.getLogger("zenav").setLevel(logging.ERROR)
    chosen = plan.only(plan.QUICK if args.quick else plan.FULL, args.only)
    if "peers" in chosen.sections:
        extras.check("wpimath", "the WPILib comparison", extra="peers")
    if args.rtf is not None:
        chosen = dataclasses.replace(chosen, rtf=args.rtf)
    args.out.mkdir(parents=True, exist_ok=True)
    res = measure(chosen, args.out, command_line(args))
    path = report.write(res, args.out)
    print(f"{path} written; the run took {res.duration:.0f} s")
    return EXIT_OK
