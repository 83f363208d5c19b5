"""`./run` on a fresh clone: two commands started together (README's `./run up`, and a
`./run zenav ...` from a second terminal while the first still installs) set up `.venv`
once, one after the other, and both run. That setup is what running needs (the camera's
packages, no test tools); `./run test` then adds the test tools to the same venv, once."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest

pytestmark = [pytest.mark.system, pytest.mark.timeout(3 * 600)]

REPO = Path(__file__).resolve().parents[2]
SETUP = 600.0  # [s] for a fresh venv's install (or its update), at most


def imports(venv: Path, module: str) -> bool:
    return subprocess.run([str(venv / "bin" / "python"), "-c", f"import {module}"], capture_output=True, timeout=120).returncode == 0


def test_run_sets_up_what_running_needs_once_and_test_adds_the_test_tools(tmp_path):
    env = {k: v for k, v in os.environ.items() if not k.startswith(("ZENAV_", "ZENOH_"))}
    venv = tmp_path / "venv"
    env["ZENAV_VENV"] = str(venv)

    def run(*args: str) -> subprocess.Popen:
        return subprocess.Popen(["./run", *args], cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)

    procs = [run("zenav", "--version") for _ in range(2)]
    outs = [p.communicate(timeout=SETUP)[0] for p in procs]
    assert [p.returncode for p in procs] == [0, 0], outs
    assert sum(o.count("setting up") for o in outs) == 1, outs
    assert all("zenav" in o.splitlines()[-1] for o in outs), outs
    assert imports(venv, "cv2") and imports(venv, "pupil_apriltags")  # the default `zenav up` runs the camera vps
    assert not imports(venv, "pytest") and not (venv / "bin" / "ruff").exists()

    out = run("test", "--version").communicate(timeout=SETUP)[0]  # with options: pytest alone, so its version
    assert "updating" in out and "pytest" in out.splitlines()[-1], out
    assert imports(venv, "pytest") and (venv / "bin" / "ruff").exists()

    outs = [run(*args).communicate(timeout=SETUP)[0] for args in (["test", "--version"], ["zenav", "--version"])]
    assert not any("setting up" in o or "updating" in o for o in outs), outs  # the test level serves both
