"""The core `zenav` command works without the optional `tools` extra (as in the docker image)."""

import os
import subprocess
import sys

import pytest

BLOCK = "import sys; sys.modules.update({m: None for m in ('mcap', 'foxglove', 'matplotlib')}); "


@pytest.mark.parametrize(
    "argv",
    [
        ["--help"],
        ["router", "--help"],
        ["up", "--help"],
        ["goto", "--help"],
        ["bench", "--help"],
        ["topics", "--help"],
        ["teleop", "--help"],
        ["completion", "bash"],
    ],
)
def test_core_commands_need_no_optional_packages(argv):
    code = BLOCK + f"from zenav.cli.main import main; sys.exit(main({argv!r}))"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr


def test_an_optional_command_says_what_is_missing():
    code = BLOCK + "from zenav.cli.main import main; sys.exit(main(['plot', 'x.mcap', '-o', 'x.png']))"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.returncode == 2 and "zenav[tools]" in done.stderr and "Traceback" not in done.stderr


def test_bench_sections_named_by_the_cli_are_the_bench_s():
    from zenav.bench.plan import SECTIONS
    from zenav.bench.printed import STUDIES
    from zenav.cli import bench

    assert bench.SECTIONS == SECTIONS and bench.STUDIES == tuple(STUDIES)


def test_output_to_a_reader_that_left_ends_quietly():
    """`zenav ... | head -1`: the reader is gone before the command writes; no traceback, exit 0."""
    read, write = os.pipe()
    os.close(read)
    try:
        code = "from zenav.cli.main import main; import sys; sys.exit(main(['completion', 'bash']))"
        done = subprocess.run([sys.executable, "-c", code], stdout=write, stderr=subprocess.PIPE, text=True, timeout=60)
    finally:
        os.close(write)
    assert done.returncode == 0 and done.stderr == ""


def test_a_pipe_is_told_apart_once_its_reader_left():
    from zenav.cli.main import reader_gone

    read, write = os.pipe()
    try:
        assert not reader_gone(write)
        os.close(read)
        assert reader_gone(write)
    finally:
        os.close(write)
