"""`zenav bench` arguments: the plan they select and the command the report names."""

from __future__ import annotations

import argparse

import pytest

from zenav.bench import plan
from zenav.cli import bench as cli


def parse(*argv: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="zenav")
    cli.add_arguments(parser.add_subparsers(dest="command"))
    return parser.parse_args(["bench", *argv])


def test_defaults_write_the_full_report_to_a_scratch_directory():
    args = parse()
    assert (args.quick, args.only, str(args.out), args.func) == (False, None, "bench-report", cli.run)
    assert cli.command_line(args) == "zenav bench --out bench-report"


def test_quick_and_sections_are_named_in_the_command():
    args = parse("--quick", "--only", "latency", "--only", "cost", "--rtf", "2", "--out", "/tmp/b")
    assert cli.command_line(args) == "zenav bench --quick --only latency --only cost --rtf 2 --out /tmp/b"
    chosen = plan.only(plan.QUICK, args.only)
    assert chosen.sections == ("latency", "cost") and chosen.limit == 120.0
    assert plan.only(plan.FULL, None).sections == plan.SECTIONS


def test_an_unknown_section_is_refused(capsys):
    with pytest.raises(SystemExit):
        parse("--only", "everything")
    assert "invalid choice" in capsys.readouterr().err
