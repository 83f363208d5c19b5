"""`zenav bench` arguments: the plan they select and the command the report names."""

from __future__ import annotations

import argparse

import pytest

from zenav.bench import chain, child, plan, safety
from zenav.bench.accuracy import Spec
from zenav.cli import bench as cli
from zenav.common.app import parse_sets


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


def test_a_camera_run_sets_the_sim_and_the_vps_alike_in_both_harnesses():
    spec = Spec(vps="camera")
    args = spec.args(2.0)
    sets = parse_sets([args[i + 1] for i, a in enumerate(args) if a == "--set"])
    assert sets["sim"] == {"rtf": 2.0, "camera": True} and sets["vps"] == {"source": "camera"}
    s = spec.settings(2.0)
    assert s.sections["sim"] == {"rtf": 2.0, "camera": True} and s.sections["vps"] == {"source": "camera"}
    assert parse_sets([a for a in Spec().args(1.0) if a.startswith("vps.")]) == {"vps": {"source": "synthetic"}}


def test_sections_named_choose_the_report_s_and_the_printed_ones():
    args = parse("latency", "safety", "studies", "calibration", "peers", "--seeds", "3", "--only", "cost")
    assert (args.sections, args.studies, args.seeds) == (["latency", "safety", "studies"], ["calibration", "peers"], 3)
    assert cli.report_sections(args) == ["latency", "cost"]
    assert cli.command_line(args) == "zenav bench latency --only cost --out bench-report"
    assert cli.report_sections(parse("link")) == [] and cli.report_sections(parse("--quick")) is None


@pytest.mark.parametrize(
    "argv, says",
    [
        (["studies"], "`studies` wants one or more of"),
        (["latency", "studies", "cost"], "unknown 'cost'"),
        (["everything"], "unknown 'everything'"),
        (["safety", "--floods", "0"], "--floods: 1 to 1000"),
    ],
)
def test_unknown_or_incomplete_sections_are_refused(capsys, argv, says):
    with pytest.raises(SystemExit) as e:
        parse(*argv)
    assert e.value.code == 2 and says in capsys.readouterr().err


def test_safety_spread_is_min_median_max_in_ms():
    assert safety._spread([0.003, 0.001, 0.002]) == "1.0 / 2.0 / 3.0"


def test_a_helper_process_runs_only_a_role_of_the_bench():
    argv = child.argv(chain.relay, "tcp/127.0.0.1:1", 2, "peer", "odom")
    assert argv[-3:] == ["chain", "relay", '["tcp/127.0.0.1:1", 2, "peer", "odom"]']
    with pytest.raises(ValueError, match="not a role"):
        child.argv(chain.measure, "tcp/127.0.0.1:1")
    assert child.main(["chain", "measure", "[]"]) == 2
    assert child.main(["os", "system", '["true"]']) == 2
