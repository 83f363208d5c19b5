"""Building the images and running docker compose, for the docker tests (the `engine` fixture is in tests/conftest.py)."""

from __future__ import annotations

import itertools
import os
import shutil
import subprocess
import sys
import threading
import time
from collections.abc import Iterable
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
BASE = os.environ.get("ZENAV_BASE", "zenav-base:bookworm")  # built by docker/build-base-image.sh if absent
IMAGE = "zenav:test"
WHEELS = "zenav-wheels:test"  # the dependencies' wheels, downloaded on the host (a build here reaches no package index)


def compose_command() -> list[str]:
    """`docker compose` (v2) if present, else `docker-compose` (v1); skip if neither."""
    if subprocess.run(["docker", "compose", "version"], capture_output=True).returncode == 0:
        return ["docker", "compose"]
    if shutil.which("docker-compose"):
        return ["docker-compose"]
    pytest.skip("neither `docker compose` nor `docker-compose` is installed")


def run(cmd: list[str], env: dict | None = None, timeout: float = 600) -> None:
    """Run a build or compose command; fail with its output if it fails."""
    proc = subprocess.run(cmd, cwd=REPO, env=env, capture_output=True, text=True, timeout=timeout)
    assert proc.returncode == 0, f"{' '.join(cmd)} exited {proc.returncode}:\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"


def no_engine() -> str | None:
    """Why no Docker engine can be used (no docker command, or no engine answers it); None if one answers."""
    if not shutil.which("docker"):
        return "the docker command is not installed"
    version = subprocess.run(["docker", "version", "--format", "{{.Server.Version}}"], capture_output=True, text=True)
    return f"no Docker engine answers: {version.stderr.strip()}" if version.returncode != 0 else None


def build_images() -> float:
    """Build the base image if absent, then the zenav image as compose builds it (the checkout
    with .dockerignore applied as its context; the dependencies from a wheels image); its size [MB]."""
    if BASE == "zenav-base:bookworm":
        run([str(REPO / "docker" / "build-base-image.sh"), BASE], timeout=1200)
    env = {**os.environ, "ZENAV_IMAGE": IMAGE, "ZENAV_BASE": BASE, "ZENAV_WHEELS": WHEELS, "PYTHON": sys.executable}
    run([str(REPO / "docker" / "build-image.sh")], env=env, timeout=1200)
    size = subprocess.run(["docker", "image", "inspect", "--format", "{{.Size}}", IMAGE], capture_output=True, text=True, check=True)
    return int(size.stdout) / 1e6


class Build:
    """The images built once a session, on a thread of their own from its start: the build
    (minutes on a fresh machine: a Debian root, every wheel installed) runs while the tests
    before the first docker test do."""

    def __init__(self) -> None:
        self._thread: threading.Thread | None = None
        self._size: float | None = None
        self._error: BaseException | None = None

    def start(self) -> None:
        """Start building, once."""
        if self._thread is None:
            self._thread = threading.Thread(target=self._build, name="image-build", daemon=True)
            self._thread.start()

    def result(self) -> float:
        """The image's size [MB], once built (starting the build if nothing did); the build's error if it failed."""
        self.start()
        assert self._thread is not None
        self._thread.join()
        if self._error is not None:
            raise self._error
        assert self._size is not None
        return self._size

    def _build(self) -> None:
        try:
            self._size = build_images()
        except BaseException as e:  # raised to each test that needs the image
            self._error = e


BUILD = Build()


class Project:
    """One compose project of docker-compose.yml (and `overrides`), on the test image: `up`,
    `ps`, its containers, Docker's health reports of them; `down` and a log dump on failure
    when used as a context manager."""

    def __init__(self, engine, env: dict[str, str], overrides: Iterable[Path] = ()) -> None:
        self.engine = engine
        self.name = f"zenavtest{os.getpid()}{next(_projects)}"
        self.env = {**os.environ, "ZENAV_IMAGE": IMAGE, **env}
        files = [REPO / "docker-compose.yml", *overrides]
        self.cmd = [*compose_command(), "--project-name", self.name, *(a for f in files for a in ("--file", str(f)))]
        self.label = f"com.docker.compose.project={self.name}"  # the label compose gives its containers

    def compose(self, *args: str) -> str:
        """Run `compose args...` in this project; its output."""
        proc = subprocess.run([*self.cmd, *args], cwd=REPO, env=self.env, capture_output=True, text=True, timeout=600)
        assert proc.returncode == 0, f"compose {' '.join(args)} exited {proc.returncode}:\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
        return proc.stdout

    def container(self, service: str):
        (c,) = self.engine.containers.list(filters={"label": [self.label, f"com.docker.compose.service={service}"]})
        return c

    def wait_healthy(self, services: Iterable[str], since: float, timeout: float) -> None:
        """Block until Docker reports each named service's container healthy (its health_status
        events since `since`, a wall-clock time before `up`); TimeoutError naming each one's last."""
        want, health = set(services), dict[str, str]()
        events = self.engine.events(
            since=int(since) - 1, until=int(time.time() + timeout) + 1, filters={"type": "container", "label": self.label}, decode=True
        )
        try:
            for event in events:  # ends at `until`
                status = event.get("status", "")
                if status.startswith("health_status:"):
                    health[event["Actor"]["Attributes"]["com.docker.compose.service"]] = status.split(":", 1)[1].strip()
                    if all(health.get(s) == "healthy" for s in want):
                        return
        finally:
            events.close()
        raise TimeoutError(f"not all healthy in {timeout:.0f} s: {health} of {sorted(want)}")

    def __enter__(self) -> Project:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        try:
            if exc_type is not None:
                for c in self.engine.containers.list(all=True, filters={"label": self.label}):
                    print(f"--- {c.name} ({c.status})\n{c.logs(tail=30).decode(errors='replace')}")
        finally:
            self.compose("down", "--volumes", "--timeout", "10")
            assert self.engine.containers.list(all=True, filters={"label": self.label}) == []


_projects = itertools.count()


def dialout_pty(link: str) -> str:
    """Give the pty `link` points at to the dialout group (gid 20 in Debian images), mode 0660,
    as udev gives a USB serial port: only a user in dialout opens it. The pty's path."""
    pty = os.path.realpath(link)
    os.chown(pty, -1, 20)
    os.chmod(pty, 0o660)
    return pty
