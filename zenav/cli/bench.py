"""`zenav bench`: measure accuracy, latency, cost and simulation speed; write the report; or print one part's tables."""

from __future__ import annotations

import argparse
import dataclasses
import logging
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from zenav.cli.main import EXIT_OK
from zenav.common import extras

# The bench's sections (bench/plan.py SECTIONS, bench/printed.py STUDIES; a test keeps them equal): named here so
# that building the parser imports none of the bench's optional packages.
SECTIONS = ("latency", "cost", "speed", "accuracy", "navigation", "settle", "planning", "camera", "peers", "profile", "fleet")
PRINTED = ("safety", "link", "studies")  # sections that print their tables, not written to the report
STUDIES = ("localizer", "localizer-latency", "localizer-pushed", "calibration", "odometry", "navigator", "peers", "onboard", "detectors")
DEFAULT_OUT = Path("bench-report")  # a scratch directory: the committed report is written with --out docs/bench


class Sections(argparse.Action):
    """SECTION... then, after `studies`, the studies' names: into `sections` and `studies`."""

    def __call__(self, parser: argparse.ArgumentParser, ns: argparse.Namespace, values: Any, option: str | None = None) -> None:
        words: list[str] = list(values)
        cut = words.index("studies") + 1 if "studies" in words else len(words)
        sections, studies = words[:cut], words[cut:]
        wrong = [w for w in sections if w not in SECTIONS + PRINTED] + [w for w in studies if w not in STUDIES]
        if wrong:
            known = f"sections: {', '.join(SECTIONS + PRINTED)}; after `studies`: {', '.join(STUDIES)}"
            raise argparse.ArgumentError(self, f"unknown {', '.join(map(repr, wrong))} ({known})")
        if "studies" in sections and not studies:
            raise argparse.ArgumentError(self, f"`studies` wants one or more of {', '.join(STUDIES)}")
        ns.sections, ns.studies = sections, studies


def _floods(text: str) -> int:
    n = int(text)
    if not 1 <= n <= 1000:
        raise argparse.ArgumentTypeError("1 to 1000")
    return n


def add_arguments(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "bench",
        help="measure accuracy, latency, cost and simulation speed; write a markdown report with plots",
        description="With no SECTION: every section of the report. The report's sections: "
        f"{', '.join(SECTIONS)}. Printed, not in the report: safety (real processes), link (the serial link), "
        f"studies NAME... (one part alone on the world model: {', '.join(STUDIES)}).",
    )
    p.add_argument("sections", nargs="*", action=Sections, metavar="SECTION", help="what to measure (default: the whole report)")
    p.add_argument("--quick", action="store_true", help="a short run for CI (under 2 minutes): fewer seeds, modes and windows")
    p.add_argument("--out", type=Path, default=DEFAULT_OUT, help=f"report directory (default {DEFAULT_OUT}/)")
    p.add_argument("--only", action="append", choices=SECTIONS, help="measure only this section of the report (repeatable)")
    p.add_argument("--rtf", type=float, help="most the accuracy runs may use (default 3; the speed study may lower it)")
    p.add_argument("--seeds", type=int, help="studies: seeds per scenario (default: each study's)")
    p.add_argument("--scenarios", nargs="+", choices=("default", "coarse", "harsh"), help="studies: the scenarios (default: each study's)")
    p.add_argument("--floods", type=_floods, default=1, help="safety: how often the stop under a flood runs (1 to 1000, default 1)")
    p.add_argument("-v", "--verbose", action="store_true", help="show the in-process services' warnings")
    p.set_defaults(func=run, sections=[], studies=[])


def report_sections(args: argparse.Namespace) -> list[str] | None:
    """The report's sections asked for: None for all of them, [] for none (only printed sections)."""
    chosen = [s for s in args.sections if s in SECTIONS] + list(args.only or [])
    if chosen:
        return chosen
    return [] if args.sections else None


def command_line(args: argparse.Namespace) -> str:
    """The report's command as it would be typed."""
    parts = ["zenav bench", *(s for s in args.sections if s in SECTIONS)] + (["--quick"] if args.quick else [])
    parts += [f"--only {s}" for s in args.only or []]
    parts += [f"--rtf {args.rtf:g}"] if args.rtf is not None else []
    return " ".join(parts + [f"--out {args.out}"])


def run(args: argparse.Namespace) -> int:
    logging.basicConfig(level=logging.WARNING, format="%(name)s %(levelname)s %(message)s", stream=sys.stderr)
    if not args.verbose:  # the stacks run in this process for accuracy: their warnings would flood the terminal
        logging.getLogger("zenav").setLevel(logging.ERROR)
    sections = report_sections(args)
    if sections != []:
        _report(args, sections)
    _printed(args)
    return EXIT_OK


def _report(args: argparse.Namespace, sections: Sequence[str] | None) -> None:
    for module in ("matplotlib", "mcap", "cv2", "serial"):  # what the sections import or run: zenav[bench] has them all
        extras.check(module, "the benchmark", extra="bench")
    from zenav.bench import plan, report
    from zenav.bench.run import run as measure

    chosen = plan.only(plan.QUICK if args.quick else plan.FULL, list(sections) if sections else None)
    if "peers" in chosen.sections:
        extras.check("wpimath", "the WPILib comparison", extra="peers")
    if args.rtf is not None:
        chosen = dataclasses.replace(chosen, rtf=args.rtf)
    args.out.mkdir(parents=True, exist_ok=True)
    res = measure(chosen, args.out, command_line(args))
    path = report.write(res, args.out)
    print(f"{path} written; the run took {res.duration:.0f} s")


def _printed(args: argparse.Namespace) -> None:
    if not set(args.sections) & set(PRINTED):
        return
    from zenav.bench import printed

    if "safety" in args.sections:
        printed.safety(args.floods)
    if "link" in args.sections:
        extras.check("serial", "the serial link bench", extra="bench")
        printed.link()
    if "peers" in args.studies:
        extras.check("wpimath", "the WPILib comparison", extra="peers")
    printed.studies(args.studies, args.seeds, args.scenarios)
