"""The package as users get it. `python -m build` makes an sdist and a wheel that `twine check --strict`
accepts, from the checkout and from what the docker build context carries (a copy made with .dockerignore's
patterns); the wheel, built from the sdist, carries every file of the package, the data files among them.
Installed (not editable) with its base dependencies only into a fresh Python 3.10 venv, `python -m zenav
--version` prints the version, the robot library imports, and the systemd unit is where docs/real-robot.md
copies it from."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
import tarfile
import zipfile
from pathlib import Path

import pytest

from zenav import __version__

pytestmark = [pytest.mark.system, pytest.mark.timeout(900)]

REPO = Path(__file__).resolve().parents[2]
PY310 = Path("/root/.pyenv/versions/3.10.13/bin/python3")  # the oldest Python the package supports
DATA = {"zenav/py.typed", "zenav/data/default.toml", "zenav/data/foxglove-layout.json", "zenav/data/zenav.service"}
BUILD = 600.0  # [s] for the two builds, at most (each sets up its own build environments)
INSTALL = 600.0  # [s] for the wheel and its dependencies into a fresh venv, at most


def dockerignore() -> list[tuple[bool, re.Pattern[str]]]:
    """.dockerignore's patterns as (excludes, regex over a path relative to the context): Go's filepath.Match,
    `**` for any number of directories, `!` for an exception; the last pattern that matches decides."""
    out = []
    for line in (REPO / ".dockerignore").read_text().splitlines():
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        exclude = not line.startswith("!")
        glob = line.lstrip("!").strip("/")
        assert "[" not in glob and "\\" not in glob, f".dockerignore: {line!r}: a pattern this test does not read"
        regex = re.escape(glob).replace(r"\*\*/", "(?:.*/)?").replace(r"\*\*", ".*").replace(r"\*", "[^/]*").replace(r"\?", "[^/]")
        out.append((exclude, re.compile(regex)))
    assert out, ".dockerignore has no patterns"
    return out


def context_copy(dest: Path) -> Path:
    """A copy of the checkout holding what `docker build .` is sent (a folder excluded: all of it)."""
    patterns = dockerignore()

    def ignore(folder: str, names: list[str]) -> list[str]:
        rel = Path(folder).relative_to(REPO)
        out = []
        for name in names:
            path = (rel / name).as_posix()
            excluded = False
            for exclude, regex in patterns:
                if regex.fullmatch(path):
                    excluded = exclude
            if excluded:
                out.append(name)
        return out

    shutil.copytree(REPO, dest, ignore=ignore, symlinks=True)
    return dest


def package_files(root: Path) -> set[str]:
    """What the package ships from a source tree, as a wheel names them: its modules, py.typed, zenav/data."""
    files = [p.relative_to(root) for p in (root / "zenav").rglob("*") if p.is_file() and "__pycache__" not in p.parts]
    return {p.as_posix() for p in files if p.suffix == ".py" or p.name == "py.typed" or p.parts[:2] == ("zenav", "data")}


@pytest.fixture(scope="module")
def dists(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """source -> the folder holding its sdist and wheel; the two built at once."""
    tmp = tmp_path_factory.mktemp("dists")
    sources = {"checkout": REPO, "docker context": context_copy(tmp / "context")}
    outdirs = {name: tmp / name.replace(" ", "-") for name in sources}
    builds = {
        name: subprocess.Popen(
            [sys.executable, "-m", "build", "--outdir", str(outdirs[name]), str(src)],  # the wheel from the sdist
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
        )
        for name, src in sources.items()
    }
    for name, proc in builds.items():
        out = proc.communicate(timeout=BUILD)[0]
        assert proc.returncode == 0, f"python -m build from the {name} failed:\n{out[-3000:]}"
    return outdirs


@pytest.mark.parametrize("source", ["checkout", "docker context"])
def test_the_sdist_and_wheel_pass_twine_and_carry_the_package(dists, source):
    folder = dists[source]
    sdist, wheel = folder / f"zenav-{__version__}.tar.gz", folder / f"zenav-{__version__}-py3-none-any.whl"
    assert sorted(p.name for p in folder.iterdir()) == sorted([sdist.name, wheel.name])  # the one version, zenav.__version__
    check = subprocess.run([sys.executable, "-m", "twine", "check", "--strict", str(sdist), str(wheel)], capture_output=True, text=True)
    assert check.returncode == 0, check.stdout + check.stderr
    expected = package_files(REPO)
    assert DATA <= expected
    in_wheel = {n for n in zipfile.ZipFile(wheel).namelist() if n.startswith("zenav/")}
    assert in_wheel == expected, f"missing: {sorted(expected - in_wheel)}; extra: {sorted(in_wheel - expected)}"
    with tarfile.open(sdist) as tar:
        in_sdist = {n.split("/", 1)[1] for n in tar.getnames() if "/" in n}
    assert {"LICENSE", "README.md", "pyproject.toml", "PKG-INFO"} | expected <= in_sdist


def test_the_wheel_alone_on_python_3_10_runs_the_command_and_the_library(dists, tmp_path):
    assert PY310.exists(), f"no Python 3.10 at {PY310} (pyenv install 3.10.13)"
    wheel = dists["docker context"] / f"zenav-{__version__}-py3-none-any.whl"
    venv = tmp_path / "venv"
    subprocess.run([str(PY310), "-m", "venv", str(venv)], check=True, timeout=120)
    python = str(venv / "bin" / "python")
    pip = [python, "-m", "pip", "install", "--quiet", "--disable-pip-version-check", "--no-compile", str(wheel)]  # base dependencies only
    done = subprocess.run(pip, capture_output=True, text=True, timeout=INSTALL)
    assert done.returncode == 0, done.stdout + done.stderr
    code = "import zenav; from zenav import Robot; print(zenav.__file__, Robot.__name__)"
    done = subprocess.run([python, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr[-3000:]
    assert done.stdout.startswith(str(venv)) and done.stdout.split()[-1] == "Robot"  # the installed package, not the checkout's
    # docs/real-robot.md's path to the systemd unit in a venv (its /opt/zenav: this one)
    cp = re.search(r"^sudo cp /opt/zenav/(\S+) /etc/systemd/system/$", (REPO / "docs" / "real-robot.md").read_text(), re.MULTILINE)
    assert cp, "docs/real-robot.md no longer copies the unit from the venv"
    assert [p.name for p in venv.glob(cp[1])] == ["zenav.service"]
    for cmd in ([python, "-m", "zenav", "--version"], [str(venv / "bin" / "zenav"), "--version"]):
        done = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, timeout=60)  # cwd: not the checkout's zenav
        assert (done.returncode, done.stdout) == (0, f"zenav {__version__}\n"), done.stderr[-3000:]


def test_readme_s_install_lines_run_as_written(tmp_path):
    """README's install block, line by line in a clone of this checkout (its `<your clone URL>`: the clone's)."""
    block = re.search(r"## Install\n.*?```sh\n(.*?)```", (REPO / "README.md").read_text(), re.DOTALL)
    assert block, "README has no install block"
    clone = tmp_path / "zenav"
    shutil.copytree(REPO, clone, ignore=shutil.ignore_patterns(".venv*", "__pycache__", "*.egg-info", "build", "dist", ".git"))
    git = ["git", "-c", "user.name=zenav", "-c", "user.email=zenav@localhost", "-C", str(clone)]
    for args in (["init", "-q"], ["add", "-A"], ["commit", "-q", "-m", "the checkout"]):
        subprocess.run([*git, *args], check=True, capture_output=True, timeout=120)
    lines = [line.split("  #")[0].strip() for line in block[1].splitlines() if line.strip()]
    assert any("<your clone URL>" in line for line in lines)
    for line in lines:
        cmd = line.replace("<your clone URL>", f"file://{clone}")
        done = subprocess.run(cmd, shell=True, cwd=clone, capture_output=True, text=True, timeout=INSTALL)
        assert done.returncode == 0, f"{line}: exit {done.returncode}\n{done.stdout[-2000:]}\n{done.stderr[-2000:]}"
    assert done.stdout == f"zenav {__version__}\n"  # the block's last line: the installed package's version
