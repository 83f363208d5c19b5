"""Building the images and running docker compose, for the docker tests (the `engine` fixture is in tests/conftest.py)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
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


def build_images(engine) -> float:
    """Build the base image if absent and the zenav image from this checkout; its size [MB]."""
    if BASE == "zenav-base:bookworm":
        run([str(REPO / "docker" / "build-base-image.sh"), BASE], timeout=1200)
    env = {**os.environ, "ZENAV_IMAGE": IMAGE, "ZENAV_BASE": BASE, "PYTHON": sys.executable}
    run([str(REPO / "docker" / "build-image.sh")], env=env)
    return engine.images.get(IMAGE).attrs["Size"] / 1e6
