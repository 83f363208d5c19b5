"""The systemd unit the package ships (zenav/data/zenav.service): `zenav up --profile robot` from the venv in
/opt/zenav at boot, as a user in dialout, restarted on failure; its command is one zenav accepts, and
`systemd-analyze verify` finds nothing to say about it."""

from __future__ import annotations

import configparser
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from zenav.cli.main import build_parser

UNIT = Path(__file__).resolve().parents[2] / "zenav" / "data" / "zenav.service"
VENV = "/opt/zenav"


def unit() -> configparser.ConfigParser:
    parser = configparser.ConfigParser(interpolation=None, strict=False)
    parser.optionxform = str  # type: ignore[assignment,method-assign]  # systemd's keys are case-sensitive
    parser.read_string(UNIT.read_text())
    return parser


def test_the_unit_runs_the_robot_profile_from_the_venv_at_boot():
    u = unit()
    argv = shlex.split(u["Service"]["ExecStart"])
    assert argv[0] == f"{VENV}/bin/zenav"
    args = build_parser().parse_args(argv[1:])
    assert (args.command, args.profile, args.demo) == ("up", "robot", False)
    assert u["Service"]["Environment"] == "ZENAV_CONFIG=/etc/zenav/robot.toml"
    assert u["Service"]["User"] not in ("", "root") and "dialout" in u["Service"]["SupplementaryGroups"].split()
    assert (u["Service"]["Restart"], u["Service"]["KillSignal"]) == ("on-failure", "SIGINT")  # SIGINT: the services stop in order
    assert "network-online.target" in u["Unit"]["After"].split() and "network-online.target" in u["Unit"]["Wants"].split()
    assert u["Install"]["WantedBy"] == "multi-user.target"


def verify(tmp_path: Path, text: str) -> str:
    """What `systemd-analyze verify` says of the unit `text` (its ExecStart's venv moved to a temporary copy: verify needs
    the binary to exist); AssertionError if it fails."""
    if not sys.platform.startswith("linux"):
        pytest.skip("systemd runs on Linux only")
    tool = shutil.which("systemd-analyze")
    assert tool, "systemd-analyze not found: apt-get install systemd"
    venv = tmp_path / VENV.lstrip("/")
    (venv / "bin").mkdir(parents=True)
    (venv / "bin" / "zenav").write_text("#!/bin/sh\n")
    (venv / "bin" / "zenav").chmod(0o755)
    path = tmp_path / "zenav.service"
    path.write_text(text.replace(f"{VENV}/", f"{venv}/"))
    done = subprocess.run([tool, "verify", str(path)], capture_output=True, text=True, timeout=60)
    said = "\n".join(line for line in (done.stdout + done.stderr).splitlines() if "zenav.service" in line)
    assert done.returncode == 0, done.stdout + done.stderr
    return said


def test_systemd_analyze_verify_finds_nothing_in_the_unit(tmp_path):
    assert verify(tmp_path, UNIT.read_text()) == ""


def test_systemd_analyze_verify_would_see_a_key_systemd_does_not_know(tmp_path):
    assert "Unknown key" in verify(tmp_path, UNIT.read_text().replace("Restart=", "Restrat="))
