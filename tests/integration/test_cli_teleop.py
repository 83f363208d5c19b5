"""`zenav teleop` in a real terminal (tmux): a key drives cmd_vel, the dead-man zeroes it, q quits."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import threading
import time
from collections.abc import Callable

import pytest

pytestmark = pytest.mark.skipif(shutil.which("tmux") is None, reason="tmux is not installed")

STARTUP = 20.0  # [s] for Python to start, import zenav and connect on a loaded machine


def poll(condition: Callable[[], bool], timeout: float) -> bool:
    """Whether `condition()` holds within `timeout` s, looking every 0.1 s (for a terminal's state)."""
    tick = threading.Event()
    for _ in range(int(timeout / 0.1) + 1):
        if condition():
            return True
        tick.wait(0.1)
    return condition()


def test_teleop_drives_stops_on_the_deadman_and_quits(router, client, tmp_path):
    commands: list[tuple[float, float, float, float]] = []  # (v, omega, t, arrival [s])
    cond = threading.Condition()

    def on_cmd(msg):
        with cond:
            commands.append((msg.v, msg.omega, msg.t, time.monotonic()))
            cond.notify_all()

    client.subscribe("cmd_vel", on_cmd)
    tmux = ["tmux", "-L", f"zenav-test-{os.getpid()}"]
    done = tmp_path / "exit-code"
    shell = f"{sys.executable} -m zenav teleop --connect {router} --deadman 300 --speed 0.25; echo $? > {done}"
    subprocess.run([*tmux, "new-session", "-d", "-s", "t", "-x", "100", "-y", "10", shell], check=True, timeout=30)
    try:

        def pane() -> str:
            return subprocess.run([*tmux, "capture-pane", "-p", "-t", "t"], capture_output=True, text=True, timeout=10).stdout

        assert poll(lambda: "teleop on zenav/r1/cmd_vel" in pane(), STARTUP), pane()
        subprocess.run([*tmux, "send-keys", "-t", "t", "Up"], check=True, timeout=10)
        with cond:
            assert cond.wait_for(lambda: any(c[0] == 0.25 for c in commands), 10.0), commands
            assert cond.wait_for(lambda: commands[-1][:2] == (0.0, 0.0), 5.0), commands  # no more keys: the dead-man
        first = next(c for c in commands if c[0] == 0.25)
        zero = commands[-1]
        assert zero[3] - first[3] >= 0.25 and all(c[2] == 0.0 for c in commands)  # held 300 ms; t = 0: "now"
        subprocess.run([*tmux, "send-keys", "-t", "t", "q"], check=True, timeout=10)
        assert poll(lambda: done.exists() and done.read_text().strip() != "", 10.0)
        assert done.read_text().strip() == "0"
    finally:
        subprocess.run([*tmux, "kill-server"], capture_output=True, timeout=10)
