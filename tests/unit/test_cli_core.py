"""The core `zenav` command works without the optional `tools` extra (as in the docker image)."""

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
    from zenav.cli.bench import SECTIONS as CLI

    assert CLI == SECTIONS
