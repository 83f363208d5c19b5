"""README's quick start, as written: `./run up` drives its demo square, from a second
terminal `./run zenav goto 0.5 0.5 --wait` wins over the demo and succeeds, and Ctrl-C
stops every service, each by itself (none killed)."""

from __future__ import annotations

import os
import queue
import signal
import subprocess
import threading
import time
from pathlib import Path

import pytest

from tests.support.procs import reaped

pytestmark = pytest.mark.system

REPO = Path(__file__).resolve().parents[2]
README = (REPO / "README.md").read_text()
UP, GOTO = "./run up", "./run zenav goto 0.5 0.5 --wait"
START = 120.0  # [s] for `./run up` to have every service alive and the demo driving
GOAL = 90.0  # [s] for the operator's goal to end


def lines_of(proc: subprocess.Popen) -> tuple[queue.Queue, threading.Thread]:
    """The process's output lines, read by a thread, so the test waits with a timeout."""
    out: queue.Queue = queue.Queue()

    def read() -> None:
        assert proc.stdout is not None
        with proc.stdout:
            for line in proc.stdout:
                out.put(line)

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    return out, reader


def wait_line(out: queue.Queue, text: str, timeout: float, seen: list[str]) -> str:
    """The first line containing `text`; AssertionError with what came after `timeout` s."""
    deadline = time.monotonic() + timeout
    while (left := deadline - time.monotonic()) > 0:
        try:
            line = out.get(timeout=left)
        except queue.Empty:
            break
        seen.append(line)
        if text in line:
            return line
    raise AssertionError(f"no line with {text!r} in {timeout} s; got:\n{''.join(seen[-30:])}")


def test_the_operator_goal_wins_over_the_running_demo(tmp_path):
    assert UP in README and GOTO in README  # the commands below are README's own
    env = {k: v for k, v in os.environ.items() if not k.startswith(("ZENAV_", "ZENOH_"))}
    env["XDG_STATE_HOME"] = str(tmp_path)  # the stack's logs
    up = subprocess.Popen(
        UP.split(), cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True
    )
    with reaped(up):
        (out, reader), seen = lines_of(up), []
        wait_line(out, "demo: driving", START, seen)
        goto = subprocess.run(GOTO.split(), cwd=REPO, env=env, capture_output=True, text=True, timeout=GOAL)
        assert goto.returncode == 0, goto.stderr + goto.stdout
        assert "succeeded" in goto.stderr + goto.stdout
        wait_line(out, "demo: paused", 10.0, seen)  # it said so on its status lines
        up.send_signal(signal.SIGINT)
        assert up.wait(timeout=30) == 0
        reader.join(timeout=10)  # to the end of its output: the pipe is closed
        while not out.empty():
            seen.append(out.get())
        said = "".join(seen)
        assert "all services stopped" in said, said[-3000:]
        assert "did not stop" not in said, said[-3000:]  # the launcher's line when it kills one
