"""The base install, the camera and a real robot resolve to ARM64 Linux wheels only (a Raspberry Pi, a Jetson):
`pip download --only-binary=:all:` for manylinux_2_28_aarch64 (and older), at the oldest and a current Python. Needs PyPI;
skipped only when pip says the index cannot be reached."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest
from packaging.markers import Marker
from packaging.requirements import Requirement

if sys.version_info >= (3, 11):
    import tomllib
else:
    import tomli as tomllib

pytestmark = pytest.mark.system

PYPROJECT = Path(__file__).resolve().parents[2] / "pyproject.toml"
EXTRAS = ("camera", "robot")
# A glibc 2.28 ARM64 Linux takes manylinux wheels of glibc 2.28 and older: pip, given the one tag, looks for no
# older ones (numpy's for Python 3.10 are manylinux_2_17), so each is named.
PLATFORMS = [f"manylinux_2_{minor}_aarch64" for minor in range(28, 16, -1)] + ["manylinux2014_aarch64"]
TIMEOUT = 900  # [s] for pip to resolve and download
# What pip prints when it cannot reach the index (and nothing else it prints).
NETWORK = re.compile(
    r"NewConnectionError|Temporary failure in name resolution|Name or service not known|Network is unreachable"
    r"|Max retries exceeded|ConnectTimeoutError|ReadTimeoutError|Connection refused"
)


def requirements(python: str) -> list[str]:
    """The base dependencies and the EXTRAS' (their `zenav[...]` references followed), as pip is to install them on an
    ARM64 Linux CPython `python` ("3.11"): markers evaluated for that machine, each requirement once."""
    project = tomllib.loads(PYPROJECT.read_text())["project"]
    optional = project["optional-dependencies"]
    target = {
        "python_version": python,
        "python_full_version": f"{python}.0",
        "platform_machine": "aarch64",
        "platform_system": "Linux",
        "sys_platform": "linux",
        "os_name": "posix",
        "implementation_name": "cpython",
        "platform_python_implementation": "CPython",
    }
    out: dict[str, str] = {}
    todo = [*project["dependencies"], *(f"zenav[{e}]" for e in EXTRAS)]
    seen: set[str] = set()
    while todo:
        req = Requirement(todo.pop(0))
        if req.marker is not None and not Marker(str(req.marker)).evaluate(target):
            continue
        if req.name == project["name"]:
            for extra in sorted(req.extras - seen):
                seen.add(extra)
                todo += optional[extra]
            continue
        req.marker = None
        out.setdefault(req.name, str(req))
    return list(out.values())


def test_the_requirements_follow_the_extras_references():
    got = requirements("3.10")
    names = [Requirement(r).name for r in got]
    assert {"eclipse-zenoh", "msgspec", "numpy", "tomli", "opencv-python-headless", "pyserial"} <= set(names)
    assert "pupil-apriltags" not in names and not any(n == "zenav" for n in names)
    assert "tomli" not in [Requirement(r).name for r in requirements("3.11")]  # only where tomllib is missing


@pytest.mark.parametrize("python", ["3.10", "3.11"])
def test_base_camera_and_robot_resolve_to_arm64_wheels_only(python, tmp_path):
    cmd = [sys.executable, "-m", "pip", "download", "--only-binary=:all:", *(a for p in PLATFORMS for a in ("--platform", p))]
    cmd += ["--python-version", python, "--implementation", "cp", "--disable-pip-version-check", "-d", str(tmp_path)]
    cmd += requirements(python)
    got = subprocess.run(cmd, capture_output=True, text=True, timeout=TIMEOUT, check=False)
    output = got.stdout + got.stderr
    if got.returncode != 0 and NETWORK.search(output):
        pytest.skip(f"the package index cannot be reached: {NETWORK.search(output).group(0)}")  # type: ignore[union-attr]
    assert got.returncode == 0, output[-3000:]
    wheels = sorted(p.name for p in tmp_path.iterdir())
    assert all(w.endswith(".whl") for w in wheels), wheels
    assert any(w.startswith("opencv_python_headless") and "aarch64" in w for w in wheels), wheels
