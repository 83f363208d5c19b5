"""Processes the system and integration tests start: `zenav up` as a stack, its service pids, stderr readers;
and the calling thread's niceness."""

from __future__ import annotations

import os
import queue
import signal
import subprocess
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from zenav.common.client import Client
from zenav.stack.inprocess import free_port


def niceness() -> int:
    """The calling thread's niceness (Linux keeps one per thread)."""
    return os.getpriority(os.PRIO_PROCESS, threading.get_native_id())


def pids(module: str, endpoint: str) -> list[int]:
    """The pids of the processes running `python -m module` with this router endpoint."""
    out = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                cmd = (d / "cmdline").read_bytes().split(b"\0")
            except OSError:
                continue
            if module.encode() in cmd and endpoint.encode() in cmd:
                out.append(int(d.name))
    return out


def service_pid(name: str, endpoint: str) -> int:
    """The pid of the service process started with this router endpoint."""
    found = pids(f"zenav.services.{name}", endpoint)
    if not found:
        raise LookupError(name)
    return found[0]


@contextmanager
def reaped(*procs: subprocess.Popen) -> Iterator[None]:
    """Kill (and wait for) each process still running when the block ends, however it ends."""
    try:
        yield
    finally:
        for proc in procs:
            if proc.poll() is None:
                proc.kill()
                proc.wait()


def stderr_lines(proc: subprocess.Popen) -> queue.Queue:
    """The process's stderr lines, read by a thread, so that a test waits for them with a timeout."""
    lines: queue.Queue = queue.Queue()

    def read() -> None:
        with proc.stderr:
            for line in proc.stderr:
                lines.put(line)

    threading.Thread(target=read, daemon=True).start()
    return lines


# The synthetic VPS instead of the sim profile's camera: the scenario's VPS errors and faults
# act, and no frame is rendered or detected on the test machine (tests/system/test_up.py runs the camera).
SYNTHETIC_VPS = ("--set", "vps.source=synthetic", "--set", "sim.camera=false")


class Stack:
    """`zenav up` as a process tree with the synthetic VPS (`extra` may set it back), with a client on its router."""

    def __init__(self, tmp, extra=(), connect=None, duration: float = 600.0) -> None:
        self.endpoint = connect or f"tcp/127.0.0.1:{free_port()}"
        where = ["--connect", self.endpoint] if connect else ["--listen", self.endpoint]
        argv = ["up", *where, "--log-dir", str(tmp), "--duration", str(duration), *SYNTHETIC_VPS, *extra]
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "zenav", *argv],
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
        )
        self.client = Client("r1", self.endpoint)
        self.truth = self.client.latest("sim/truth")
        self.nav = self.client.latest("nav/state")
        self.speeds: list[tuple[float, float]] = []  # (t, |v|) of every truth sample
        self.client.subscribe("sim/truth", lambda msg: self.speeds.append((msg.t, abs(msg.v))))

    def diag(self, name):
        """The latest diag of one service."""
        return self.client.latest(f"diag/{name}")

    def close(self) -> str:
        """Stop the stack (SIGINT, then kill after 60 s); returns its output."""
        self.client.close()
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
        try:
            out, _ = self.proc.communicate(timeout=60)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            out, _ = self.proc.communicate()
        return out
