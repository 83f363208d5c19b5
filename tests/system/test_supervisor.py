"""`zenav up`'s supervisor on real processes: a hung (SIGSTOPped) service is restarted, a crash loop is given up."""

from __future__ import annotations

import os
import signal

import pytest

from tests.support.procs import Stack, service_pid

pytestmark = pytest.mark.system


def restarted(stack: Stack, name: str, old_pid: int, timeout: float = 30.0) -> int:
    """Wait for a new process of `name` to publish its diag; its pid. (Its uptime cannot
    tell: a restarted service's first diag may show more than the killed one's last.)"""

    def new_process(_diag: object) -> bool:
        try:
            return service_pid(name, stack.endpoint) != old_pid
        except LookupError:  # not restarted yet
            return False

    stack.diag(name).wait(new_process, timeout=timeout)
    pid = service_pid(name, stack.endpoint)
    assert pid != old_pid
    return pid


def test_a_hung_service_is_killed_and_restarted(tmp_path):
    stack = Stack(tmp_path, ["--services", "sim,motor", "--hang-after", "3"])
    try:
        stack.client.wait_alive(["sim", "motor"], timeout=90)
        stack.diag("motor").wait(lambda d: d.uptime > 1.0, timeout=30)
        pid = service_pid("motor", stack.endpoint)
        os.kill(pid, signal.SIGSTOP)  # alive, but silent
        restarted(stack, "motor", pid)
        assert stack.proc.poll() is None  # the stack runs on
    finally:
        out = stack.close()
    assert "motor hung (no diag for 3." in out, out
    assert "motor killed by SIGKILL (hung: no diag for 3." in out, out
    assert "motor restarted" in out, out
    assert stack.proc.returncode == 0, out
    assert "motor hung" in (tmp_path / "launcher.log").read_text()


def test_a_crash_loop_is_given_up_degraded_or_stopping_the_robot_if_essential(tmp_path):
    stack = Stack(tmp_path, ["--services", "sim,motor,odometry", "--max-crashes", "1", "--crash-window", "600"])
    try:
        stack.client.wait_alive(["sim", "motor", "odometry"], timeout=90)
        stack.diag("odometry").wait(lambda d: d.uptime > 0.5, timeout=30)
        pid = service_pid("odometry", stack.endpoint)
        os.kill(pid, signal.SIGKILL)
        os.kill(restarted(stack, "odometry", pid), signal.SIGKILL)  # the second exit: given up
        motor = stack.diag("motor")
        seen = motor.count
        motor.wait(lambda d: motor.count >= seen + 3, timeout=15)  # the rest runs on
        assert stack.proc.poll() is None
        pid = service_pid("motor", stack.endpoint)
        os.kill(pid, signal.SIGKILL)
        os.kill(restarted(stack, "motor", pid), signal.SIGKILL)  # the motor cannot run: everything stops
        stack.proc.wait(timeout=60)
    finally:
        out = stack.close()
    assert "odometry gave up: 2 exits in 600 s, the last killed by SIGKILL" in out, out
    assert "running degraded without odometry" in out, out
    assert "motor gave up: 2 exits in 600 s" in out, out
    assert "motor cannot run: stopping the robot (zero command) and every service" in out, out
    assert "all services stopped" in out, out
    assert stack.proc.returncode == 3, out
    with pytest.raises(LookupError):
        service_pid("sim", stack.endpoint)
