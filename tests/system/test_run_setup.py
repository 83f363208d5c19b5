"""`./run` on a fresh clone: two commands started together (README's `./run up`, and a
`./run zenav ...` from a second terminal while the first still installs) set up `.venv`
once, one after the other, and both run."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest

pytestmark = pytest.mark.system

REPO = Path(__file__).resolve().parents[2]
SETUP = 600.0  # [s] for a fresh venv's install, at most


def test_two_commands_on_a_fresh_venv_set_it_up_once_and_both_run(tmp_path):
    env = {k: v for k, v in os.environ.items() if not k.startswith(("ZENAV_", "ZENOH_"))}
    env["ZENAV_VENV"] = str(tmp_path / "venv")
    cmd = ["./run", "zenav", "--version"]
    procs = [subprocess.Popen(cmd, cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True) for _ in range(2)]
    outs = [p.communicate(timeout=SETUP)[0] for p in procs]
    assert [p.returncode for p in procs] == [0, 0], outs
    assert sum(o.count("setting up") for o in outs) == 1, outs
    assert all("zenav" in o.splitlines()[-1] for o in outs), outs
