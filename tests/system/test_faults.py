"""Faults injected for real: kill -9 each service mid-goal, and restart the router."""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import threading
import time

import pytest

from tests.support import goals
from tests.support.procs import Stack, service_pid
from zenav.common import messages as m
from zenav.common.client import Client, ZenavError
from zenav.services import NAMES
from zenav.stack.inprocess import free_port

pytestmark = pytest.mark.system

STOP_SPEED = 0.01  # [m/s] "stopped"
STOP_WITHIN = 0.6  # [s] of stack time after the kill
RESTART_WITHIN = 2.0  # [s] wall time for the launcher to bring the service back
# Services the robot needs to move safely: losing one must stop it.
NEEDED_FOR_MOTION = ("navigator", "motor", "localizer", "odometry")


@pytest.fixture(scope="module")
def stack(tmp_path_factory):
    s = Stack(tmp_path_factory.mktemp("faults"))
    s.client.wait_alive(NAMES, timeout=90)
    yield s
    print(s.close())


class TokenEvents:
    """Every appearance and disappearance of one service's liveliness token."""

    def __init__(self, client: Client, name: str) -> None:
        self.cond = threading.Condition()
        self.events: list[bool] = []
        self.handle = client.bus.watch_tokens(client.key(f"alive/{name}"), self._on)

    def _on(self, key: str, alive: bool) -> None:
        with self.cond:
            self.events.append(alive)
            self.cond.notify_all()

    def wait_gone_and_back(self, timeout: float) -> None:
        """Block until the token went away and came back after that."""

        def back() -> bool:
            return False in self.events and True in self.events[self.events.index(False) :]

        with self.cond:
            assert self.cond.wait_for(back, timeout), f"token events: {self.events}"

    def close(self) -> None:
        self.handle.undeclare()


def start_goal(stack: Stack) -> int:
    """A long goal away from where the robot is; returns its id once the robot moves."""
    goals.wait_ready(stack.client, timeout=30)
    tr = stack.truth.wait(timeout=10)
    x = -0.75 if tr.x > 0.75 else 2.5  # inside the default [field] (-1 to 3 m), at least 1.5 m away
    rep = stack.client.query("nav/move_to_point", {"x": x, "y": tr.y}, timeout=10)
    stack.truth.wait(lambda t: abs(t.v) > 0.1, timeout=20)
    return rep.goal_id


@pytest.mark.parametrize("name", ["navigator", "motor", "localizer", "odometry", "vps", "sim"])
def test_kill_9_mid_goal(stack, name):
    stack.client.wait_alive(NAMES, timeout=30)
    stack.diag(name).wait(timeout=10)
    goal = start_goal(stack)
    old_pid = service_pid(name, stack.endpoint)
    tokens = TokenEvents(stack.client, name)
    t_kill = stack.truth.msg.t
    wall_kill = time.monotonic()
    os.kill(old_pid, signal.SIGKILL)
    # back within 2 s: a new process whose token is up
    tokens.wait_gone_and_back(timeout=15)
    tokens.close()
    restarted_after = time.monotonic() - wall_kill
    assert service_pid(name, stack.endpoint) != old_pid
    assert restarted_after <= RESTART_WITHIN + 1.0, f"{name} back after {restarted_after:.2f} s"
    if name in NEEDED_FOR_MOTION:
        stack.truth.wait(lambda t: t.t > t_kill + STOP_WITHIN, timeout=10)
        t_stop = next(t for t, v in list(stack.speeds) if t > t_kill and v < STOP_SPEED)
        print(f"{name}: stopped {t_stop - t_kill:.2f} s after the kill, back after {restarted_after:.2f} s")
        assert t_stop - t_kill <= STOP_WITHIN, f"{name}: stopped {t_stop - t_kill:.2f} s after the kill"
        if name != "navigator":  # a restarted navigator knows no old goal; the others see it end
            st = stack.nav.wait(lambda s: s.goal_id == goal and s.result is not None, timeout=10)
            assert st.result == "aborted" and st.message, st
    if name == "sim":  # the world restarted at t = 0: the whole stack follows, a goal works again
        stack.client.wait_alive(NAMES, timeout=30)
        stack.client.latest("pose").wait(lambda p: p.t < 5.0, timeout=20)
        rep = goals.move_to_point(stack.client, 0.3, 0.0, timeout=60)
        assert rep.result == "succeeded", rep
    try:
        stack.client.query("nav/stop", timeout=5)
    except ZenavError:
        pass


CLOCK_FOLLOWERS = ("odometry", "vps", "localizer", "navigator", "motor")  # every service on the sim's clock


def clock_counts(stack: Stack, name: str) -> tuple[int, int]:
    """(clock_resets, clock_foreign) of a service, from a diag newer than now."""
    t = stack.truth.wait(timeout=10).t
    d = stack.diag(name).wait(lambda d: d.t > t, timeout=10)
    return d.counters.get("clock_resets", 0), d.counters.get("clock_foreign", 0)


def test_a_stray_clock_tick_changes_nothing_and_a_sim_restart_is_followed(stack):
    """A clock tick 5 s behind from another session (a replay, a second sim, any client) is no restart;
    the sim killed and restarted (a new instance) is."""
    stack.client.wait_alive(NAMES, timeout=30)
    goals.wait_ready(stack.client, timeout=30)
    before = {name: clock_counts(stack, name) for name in CLOCK_FOLLOWERS}
    now = stack.truth.wait(timeout=10).t
    with Client("r1", stack.endpoint) as stray:
        stray.publish("clock", m.Clock(t=max(now - 5.0, 0.0), wall=time.time(), instance="replayed-sim"))
        stray.publish("clock", m.Clock(t=max(now - 5.0, 0.0), wall=time.time()))
    stack.diag("navigator").wait(
        lambda d: d.counters.get("clock_foreign", 0) > before["navigator"][1] or d.counters.get("clock_resets", 0) > before["navigator"][0],
        timeout=10,
    )
    rep = stack.client.query("nav/move_to_point", {"x": stack.truth.msg.x + 0.2, "y": stack.truth.msg.y}, timeout=10)  # at once
    after = {name: clock_counts(stack, name) for name in CLOCK_FOLLOWERS}
    print(f"clock (resets, foreign) before {before}, after {after}")
    for name in CLOCK_FOLLOWERS:
        assert after[name] == (before[name][0], before[name][1] + 2), (name, before[name], after[name])
    st = stack.nav.wait(lambda s: s.goal_id == rep.goal_id and s.result is not None, timeout=60)
    assert st.result == "succeeded", st
    old_pid = service_pid("sim", stack.endpoint)
    os.kill(old_pid, signal.SIGKILL)  # a real restart: a new sim instance owns the clock
    stack.diag("navigator").wait(lambda d: d.counters.get("clock_resets", 0) > before["navigator"][0], timeout=30)
    assert service_pid("sim", stack.endpoint) != old_pid
    rep = goals.move_to_point(stack.client, 0.3, 0.0, timeout=60)
    assert rep.result == "succeeded", rep


def stopped_by_sim(diag) -> int:
    """How often the sim stopped the wheels by itself."""
    return diag.counters.get("command_timeouts", 0) + diag.counters.get("motor_lost_stops", 0)


def test_router_restart(tmp_path):
    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    router_cmd = [sys.executable, "-m", "zenav", "router", "--listen", endpoint]
    router = subprocess.Popen(router_cmd, stderr=subprocess.PIPE, text=True)
    assert "listening" in router.stderr.readline()
    stack = Stack(tmp_path, connect=endpoint)
    try:
        stack.client.wait_alive(NAMES, timeout=90)
        start_goal(stack)
        sim_stops = stopped_by_sim(stack.diag("sim").wait(timeout=5))
        before = stack.truth.msg  # the last truth before the kill
        router.kill()
        router.wait()
        router.stderr.close()
        time.sleep(3.0)  # the outage itself: nothing to wait on while the router is gone
        router = subprocess.Popen(router_cmd, stderr=subprocess.PIPE, text=True)
        assert "listening" in router.stderr.readline()
        back = time.monotonic()  # services may be back already: they retry every 0.5 s at most
        stack.client.wait_alive(NAMES, timeout=30)
        reconnected = time.monotonic() - back
        after = stack.truth.wait(lambda t: t.t > before.t + 3.0, timeout=10)
        # the sim stopped its wheels by itself: the motor's token went with the router
        # (or, failing that, no command for half a second)
        moved = math.hypot(after.x - before.x, after.y - before.y)
        assert moved < 0.10, f"robot moved {moved:.2f} m during a 3 s outage"
        stack.diag("sim").wait(lambda d: stopped_by_sim(d) > sim_stops, timeout=10)
        print(
            f"router restart: all services back {reconnected:.2f} s after the router listened; "
            f"robot moved {moved * 100:.1f} cm from t={before.t:.2f} (v={before.v:.3f}) to t={after.t:.2f}"
        )
        assert reconnected <= 2.0, f"services back {reconnected:.2f} s after the router"
    finally:
        out = stack.close()
        router.send_signal(signal.SIGINT)
        router.wait(10)
        router.stderr.close()
    assert "restarted" not in out, out  # nobody exited: they reconnected by themselves
