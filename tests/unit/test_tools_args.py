"""`zenav record`, `view`, `replay` and `plot` refuse bad arguments, config and input files before connecting: one line, exit 2."""

from __future__ import annotations

import argparse

import pytest

from zenav.cli.checks import zenoh_reason
from zenav.cli.main import EXIT_USAGE, build_parser

NOWHERE = "tcp/127.0.0.1:1"  # never reached: every case fails before connecting


def parse(*argv: str) -> argparse.Namespace:
    return build_parser().parse_args(argv)


@pytest.fixture
def files(tmp_path):
    text = tmp_path / "notes.mcap"
    text.write_text("not a recording\n")
    (tmp_path / "crashed.mcap.part").write_text("a recording whose recorder died\n")
    return {"text": str(text), "out": str(tmp_path / "out.mcap"), "dir": str(tmp_path)}


CASES = [
    (("record", "{out}", "--robot", "a/b"), "robot id 'a/b'"),
    (("record", "{out}", "--duration", "0"), "--duration must be > 0"),
    (("record", "{dir}/no/such/out.mcap"), "not a file in an existing directory"),
    (("record", "{dir}"), "not a file in an existing directory"),
    (("record", "{dir}/crashed.mcap"), "crashed.mcap.part exists (a recording not closed cleanly)"),
    (("record", "{out}", "--config", "{dir}/none.toml"), "none.toml"),
    (("record", "{out}", "--set", "sim.rtf"), "expected SECTION.KEY=VALUE"),
    (("view", "--robot", "a b"), "robot id 'a b'"),
    (("view", "--port", "70000"), "not a port number"),
    (("replay", "{text}"), "not an MCAP file"),
    (("replay", "{dir}"), "is a directory"),
    (("replay", "{out}"), "no such file"),
    (("replay", "{text}", "--from-robot", "a/b"), "--from-robot: robot id 'a/b'"),
    (("replay", "{text}", "--topics", "odmo"), "unknown topics: odmo"),
    (("replay", "{text}", "--rate", "nan"), "--rate must be >= 0"),
    (("plot", "{text}", "-o", "{dir}/x.png"), "not an MCAP file"),
    (("plot", "{text}", "-o", "{dir}/x.png", "--robot", "a/b"), "robot id 'a/b'"),
]


@pytest.mark.parametrize("argv, says", CASES, ids=[" ".join(a[:3]) for a, _ in CASES])
def test_bad_arguments_fail_with_one_line_before_connecting(files, capsys, argv, says):
    argv = tuple(a.format(**files) for a in argv)
    connect = ("--connect", NOWHERE) if argv[0] != "plot" else ()
    args = parse(*argv, *connect)
    assert args.func(args) == EXIT_USAGE
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"zenav {argv[0]}: ") and says in err, err


def test_zenoh_errors_lose_their_rust_source_line():
    class Fake(Exception):
        pass

    reason = "Unable to connect to any of [Single(tcp/127.0.0.1:1)]. Timeout!"
    text = f"{reason} at /root/.cargo/git/checkouts/zenoh/src/net/runtime/orchestrator.rs:388."
    assert zenoh_reason(Fake(text)) == reason  # type: ignore[arg-type]
