"""A service process (`python -m zenav.services.<svc>`): a bad config exits 2 before any
connection attempt; with no router it waits, saying so, stops on Ctrl-C, and joins the
router once it comes; a signal stops it whenever it lands, and so does its launcher's going."""

from __future__ import annotations

import os
import queue
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager

from zenav.common.app import CONNECT_STEP
from zenav.common.client import Client
from zenav.stack.inprocess import free_port
from zenav.stack.router import Router

EXIT_WAIT = 10.0  # [s] a stopped service exits within this (a connection attempt lasts CONNECT_STEP)


# The motor service in a process that may not take a real-time priority: without CAP_SYS_NICE in its bounding set
# (run as root: the drop needs CAP_SETPCAP, and without it there is no CAP_SYS_NICE to drop) and no rtprio limit.
UNPRIVILEGED = """
import ctypes, os, resource, sys
PR_CAPBSET_DROP, CAP_SYS_NICE = 24, 23
ctypes.CDLL(None, use_errno=True).prctl(PR_CAPBSET_DROP, CAP_SYS_NICE, 0, 0, 0)
resource.setrlimit(resource.RLIMIT_RTPRIO, (0, 0))
os.execv(sys.executable, [sys.executable, "-m", "zenav.services.motor", *sys.argv[1:]])
"""


@contextmanager
def motor(*args: str, unprivileged: bool = False) -> Iterator[tuple[subprocess.Popen, queue.Queue]]:
    """The motor service as a process, and a queue of its stderr lines; killed at the end if still running."""
    env = {**os.environ, "ZENAV_LOG": "INFO"}
    head = [sys.executable, "-c", UNPRIVILEGED] if unprivileged else [sys.executable, "-m", "zenav.services.motor"]
    proc = subprocess.Popen([*head, *args], stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True, env=env)
    assert proc.stderr is not None
    lines: queue.Queue = queue.Queue()
    pump = threading.Thread(target=lambda: [lines.put(line) for line in proc.stderr], daemon=True)  # type: ignore[union-attr]
    pump.start()
    try:
        yield proc, lines
    finally:
        proc.kill()
        proc.wait()
        pump.join(timeout=EXIT_WAIT)
        proc.stderr.close()


def wait_line(lines: queue.Queue, words: str, timeout: float) -> str:
    """The first stderr line containing `words` within `timeout` [s]."""
    deadline = time.monotonic() + timeout
    while (left := deadline - time.monotonic()) > 0:
        try:
            line = lines.get(timeout=left)
        except queue.Empty:
            break
        if words in line:
            return line
    raise AssertionError(f"no line with {words!r} within {timeout} s")


def test_a_bad_config_exits_2_with_one_line_before_connecting():
    port = free_port()  # nobody listens: a connection attempt would wait
    t0 = time.monotonic()
    out = subprocess.run(
        [sys.executable, "-m", "zenav.services.motor", "--connect", f"tcp/127.0.0.1:{port}", "--set", "motor.no_such_key=1"],
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert out.returncode == 2
    assert out.stderr.strip().splitlines() == [out.stderr.strip()] and "no_such_key" in out.stderr
    assert "router" not in out.stderr
    assert time.monotonic() - t0 < 30


def test_with_no_router_it_waits_saying_so_and_ctrl_c_stops_it():
    with motor("--connect", f"tcp/127.0.0.1:{free_port()}") as (proc, lines):
        assert "no router at" in wait_line(lines, "no router", timeout=CONNECT_STEP + 20)
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=EXIT_WAIT) == 0


def test_a_service_started_before_its_router_joins_it_when_it_comes():
    port = free_port()
    with motor("--connect", f"tcp/127.0.0.1:{port}") as (proc, lines):
        wait_line(lines, "no router", timeout=CONNECT_STEP + 20)
        with Router(port) as router, Client("r1", router.endpoint) as client:
            assert client.wait_alive(["motor"], timeout=CONNECT_STEP + 20) == {"motor"}
            proc.send_signal(signal.SIGINT)
            assert proc.wait(timeout=EXIT_WAIT) == 0


def test_a_realtime_priority_the_host_refuses_is_logged_counted_in_diag_and_the_service_runs_on():
    with Router(free_port()) as router, Client("r1", router.endpoint) as client:
        diag = client.latest("diag/motor")
        args = ("--connect", router.endpoint, "--set", "deployment.realtime=5", "--set", 'deployment.clock="wall"')
        with motor(*args, unprivileged=True) as (proc, lines):
            assert "real-time priority 5 refused" in wait_line(lines, "real-time priority", timeout=CONNECT_STEP + 20)
            assert client.wait_alive(["motor"], timeout=CONNECT_STEP + 20) == {"motor"}
            assert diag.wait(timeout=10.0).counters["realtime_refused"] == 1
            assert os.sched_getscheduler(proc.pid) == os.SCHED_OTHER
            proc.send_signal(signal.SIGINT)
            assert proc.wait(timeout=EXIT_WAIT) == 0


# The handler runs on the main thread between two Python steps: here, while that thread holds the
# lock Event.wait holds on its way in and out (as a service's worker holds its inbox's). A handler
# that took that lock itself would wait for it forever.
SIGNAL_IN_A_LOCK = """
import os, signal
from zenav.common.app import stop_on_signals
done = stop_on_signals()
with done._cond:
    os.kill(os.getpid(), signal.SIGTERM)
    [abs(i) for i in range(1000)]  # Python steps: the handler runs in one of them, the lock still held
print("stopped" if done.wait(5.0) else "not stopped", flush=True)
"""


def test_a_signal_that_comes_while_the_main_thread_holds_a_lock_still_stops_it():
    out = subprocess.run([sys.executable, "-c", SIGNAL_IN_A_LOCK], capture_output=True, text=True, timeout=EXIT_WAIT)
    assert out.stdout.strip() == "stopped", out.stderr


# A launcher that goes without stopping its child (killed by SIGKILL, say): the child is left behind.
LAUNCHER = """
import os, subprocess, sys
env = {**os.environ, "ZENAV_PARENT_PID": str(os.getpid()), "ZENAV_LOG": "INFO"}
with open(sys.argv[2], "w") as log:
    child = subprocess.Popen([sys.executable, "-m", "zenav.services.motor", "--connect", sys.argv[1]], env=env, stdout=log, stderr=log)
print(child.pid, flush=True)
sys.stdin.readline()
os._exit(0)
"""


def test_a_service_whose_launcher_is_gone_stops_by_itself(tmp_path):
    log = tmp_path / "motor.log"
    with Router(free_port()) as router, Client("r1", router.endpoint) as client:
        gone = threading.Event()
        client.bus.watch_tokens(client.key("alive/motor"), lambda key, up: None if up else gone.set())
        launcher = subprocess.Popen(
            [sys.executable, "-c", LAUNCHER, router.endpoint, str(log)], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True
        )
        assert launcher.stdin is not None and launcher.stdout is not None
        pid = int(launcher.stdout.readline())
        try:
            assert client.wait_alive(["motor"], timeout=CONNECT_STEP + 20) == {"motor"}
            launcher.stdin.write("go\n")
            launcher.stdin.close()
            assert launcher.wait(timeout=EXIT_WAIT) == 0
            assert gone.wait(EXIT_WAIT)  # its token withdrawn: it stopped
        finally:
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            launcher.stdout.close()
    assert "gone: stopping" in log.read_text()
