"""Building the images and running docker compose, for the docker tests (the `engine` fixture is in tests/conftest.py)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import threading
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
BASE = os.environ.get("ZENAV_BASE", "zenav-base:bookworm")  # built by docker/build-base-image.sh if absent
IMAGE = "zenav:test"


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
    """Build the base image if absent and the zenav image from this checkout; its size [MB]."""
    if BASE == "zenav-base:bookworm":
        run([str(REPO / "docker" / "build-base-image.sh"), BASE], timeout=1200)
    env = {**os.environ, "ZENAV_IMAGE": IMAGE, "ZENAV_BASE": BASE, "PYTHON": sys.executable}
    run([str(REPO / "docker" / "build-image.sh")], env=env)
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
