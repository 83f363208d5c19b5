"""The process launcher with real child processes: restart with backoff, crash-loop give-up, hang detection,
bounded logs, stop order, stop grace, /proc, the router process."""

from __future__ import annotations

import os
import signal
import sys
import threading
import time
from pathlib import Path

import pytest

from zenav import services
from zenav.common.client import Client
from zenav.stack import launcher
from zenav.stack.launcher import BACKOFF_FIRST, FIRST_BEAT, HANG_GRACE, STABLE_AFTER, Launcher, ProcStack, read_proc

READY = "import sys; print('ready', flush=True); "
TERM_LOG = "import os, signal, sys; log = sys.argv[1]; "
TERM_HANDLER = "signal.signal(signal.SIGTERM, lambda *a: (open(log, 'a').write(sys.argv[2] + chr(10)), os._exit(0))); "
FOREVER = "import threading; threading.Event().wait(120)"
DEAF = "import signal; signal.signal(signal.SIGTERM, signal.SIG_IGN); "  # ignores SIGTERM


class Clock:
    """A launcher clock the test moves by hand [s]."""

    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


def wait_for(cond, timeout: float = 20.0) -> None:
    """Poll `cond` until it holds (bounded in time and count)."""
    tick = threading.Event()
    for _ in range(int(timeout / 0.01)):
        if cond():
            return
        tick.wait(0.01)
    raise AssertionError("condition not met in time")


def ready(child: launcher.Child) -> bool:
    return child.log.path.exists() and "ready" in child.log.path.read_text()


def test_a_crashing_child_is_restarted_with_a_doubling_backoff(tmp_path):
    clock, events = Clock(), []
    sup = Launcher(tmp_path, events=events.append, now=clock)
    child = sup.add("crash", [sys.executable, "-c", "import sys; print('boom', flush=True); sys.exit(3)"])
    sup.start_all()
    delays = []
    for restart in range(1, 4):
        assert child.proc is not None
        child.proc.wait(timeout=20)
        sup.poll()  # notices the exit
        assert child.restart_at is not None
        delays.append(child.restart_at - clock.t)
        clock.t = child.restart_at - 0.01
        sup.poll()
        assert child.restarts == restart - 1  # not yet
        clock.t = child.restart_at
        sup.poll()
        assert child.restarts == restart and child.restart_at is None
    assert delays == [BACKOFF_FIRST, 2 * BACKOFF_FIRST, 4 * BACKOFF_FIRST]
    assert "crash exit code 3 after 0.0 s: boom; restarting in 0.5 s" in events
    assert "crash restarted" in events[-1] and "restart 3" in events[-1]
    # a run that lasted STABLE_AFTER resets the backoff
    assert child.proc is not None
    child.proc.wait(timeout=20)
    clock.t += STABLE_AFTER
    sup.poll()
    assert child.restart_at == clock.t + BACKOFF_FIRST
    sup.stop([])
    sup.close()


def crash_once(sup: Launcher, child: launcher.Child, clock: Clock) -> list[str]:
    """Let the child's current run exit, poll, and move the clock to its restart; returns what gave up."""
    assert child.proc is not None
    child.proc.wait(timeout=20)
    gave_up = sup.poll()
    if child.restart_at is not None:
        clock.t = child.restart_at
        sup.poll()
    return gave_up


def test_a_crash_loop_is_given_up_with_its_last_exit_and_log_line(tmp_path):
    clock, events = Clock(), []
    sup = Launcher(tmp_path, events=events.append, now=clock, max_crashes=2, crash_window=60.0)
    child = sup.add("vps", [sys.executable, "-c", "import sys; print('no camera', flush=True); sys.exit(4)"])
    sup.start_all()
    assert crash_once(sup, child, clock) == [] and crash_once(sup, child, clock) == []
    assert child.restarts == 2
    assert crash_once(sup, child, clock) == ["vps"]  # the third exit within 60 s
    assert child.gave_up == "3 exits in 60 s, the last exit code 4: no camera"
    assert events[-1] == "vps gave up: 3 exits in 60 s, the last exit code 4: no camera"
    assert events[-1] in (tmp_path / "launcher.log").read_text()
    clock.t += 100.0
    assert sup.poll() == [] and child.restarts == 2 and child.restart_at is None  # never restarted again
    sup.stop([])
    sup.close()


def test_crashes_spread_wider_than_the_window_are_not_a_loop(tmp_path):
    clock = Clock()
    sup = Launcher(tmp_path, events=lambda line: None, now=clock, max_crashes=1, crash_window=10.0)
    child = sup.add("odometry", [sys.executable, "-c", "import sys; sys.exit(1)"])
    sup.start_all()
    for _ in range(3):
        assert crash_once(sup, child, clock) == []
        clock.t += 10.0
    assert child.restarts == 3 and not child.gave_up
    sup.stop([])
    sup.close()


def test_hang_decision_follows_the_heartbeats_on_a_fake_clock(tmp_path):
    clock = Clock()
    sup = Launcher(tmp_path, events=lambda line: None, now=clock, hang_after=3.0)
    motor, sim = sup.add("motor", []), sup.add("sim", [])
    motor.started = sim.started = clock.t
    sup.beat("motor")
    assert sup.silence(sim, clock.t + FIRST_BEAT - 0.1) is None  # no heartbeat yet: still starting
    clock.t += 1.0
    sup.beat("sim")
    sup.beat("motor")
    clock.t += 2.0
    sup.beat("sim")
    assert sup.silence(motor, clock.t) == pytest.approx(2.0)
    assert sup.silence(sim, clock.t) == pytest.approx(0.0)
    clock.t += 2.0
    sup.beat("sim")
    assert sup.silence(motor, clock.t) == pytest.approx(4.0)  # hung: the sim is heard, the motor is not
    clock.t += 5.0  # nobody heard (the router, or the stack clock, stalled): nobody is hung
    assert sup.silence(motor, clock.t) is None and sup.silence(sim, clock.t) is None
    sup.beat("sim")  # heard again: silences count from now
    clock.t += 2.5
    sup.beat("sim")
    assert sup.silence(motor, clock.t) == pytest.approx(2.5)
    vps = sup.add("vps", [])  # a run that never beats is hung once FIRST_BEAT passed
    vps.started = clock.t
    for _ in range(int(FIRST_BEAT) + 1):
        clock.t += 1.0
        sup.beat("sim")
    assert sup.silence(vps, clock.t) == pytest.approx(int(FIRST_BEAT) + 1.0)
    assert sup.silence(vps, clock.t - 1.5) is None
    sup.close()


def test_nobody_is_found_hung_while_nobody_is_heard_whichever_beat_came_last(tmp_path):
    """The router goes: the sim's last diag came 0.5 s after the motor's. The motor's silence must not pass
    the limit before the launcher's own silence excuses everyone."""
    clock = Clock()
    sup = Launcher(tmp_path, events=lambda line: None, now=clock, hang_after=3.0)
    motor, sim = sup.add("motor", []), sup.add("sim", [])
    motor.started = sim.started = clock.t
    sup.beat("motor")
    sup.beat("sim")
    clock.t += 1.0
    sup.beat("motor")
    clock.t += 0.5
    sup.beat("sim")  # then nothing from anyone
    for dt in (1.0, 2.5, 2.9):  # the last: 2.9 s after anyone's beat, 3.4 s after the motor's
        assert sup.silence(motor, clock.t + dt) == pytest.approx(0.5)  # what the others were heard beyond it
    assert sup.silence(motor, clock.t + 3.1) is None  # nobody heard for longer than the limit: excused
    sup.close()


def test_a_hung_child_is_terminated_killed_after_the_grace_and_restarted(tmp_path):
    clock, events = Clock(), []
    sup = Launcher(tmp_path, events=events.append, now=clock, hang_after=3.0)
    child = sup.add("navigator", [sys.executable, "-c", DEAF + READY + FOREVER])
    sup.start_all()
    wait_for(lambda: ready(child))
    sup.beat("navigator")
    clock.t += 3.0
    sup.beat("sim")  # another child is heard: the launcher's link works
    sup.poll()
    assert child.hangs == 0  # 3 s is not more than 3 s
    clock.t += 0.5
    sup.beat("sim")
    sup.poll()
    assert child.hangs == 1 and child.kill_at == clock.t + HANG_GRACE
    assert events[-1].startswith("navigator hung (no diag for 3.5 s; alive pid")
    first = child.proc
    assert first is not None and first.poll() is None  # SIGTERM ignored
    clock.t += HANG_GRACE
    sup.poll()  # SIGKILL
    assert first.wait(timeout=20) == -signal.SIGKILL
    sup.poll()  # the exit, as a crash
    assert child.last_exit == "killed by SIGKILL (hung: no diag for 3.5 s)"
    assert child.restart_at is not None and "navigator killed by SIGKILL (hung: no diag for 3.5 s) after 5.5 s: ready" in events[-1]
    clock.t = child.restart_at
    sup.poll()
    assert child.restarts == 1 and child.proc is not first and child.hung == ""
    sup.stop([])
    sup.close()


def test_a_chatty_child_never_blocks_and_its_log_stays_bounded(tmp_path):
    sup = Launcher(tmp_path, events=lambda line: None, log_bytes=100_000, log_files=3)
    say = "import sys\nfor i in range(30000): print(f'{i:06d}', 'x' * 100)\nprint('last', flush=True)"
    child = sup.add("chatty", [sys.executable, "-c", say])  # 3 MB: far more than a pipe holds
    sup.start_all()
    assert child.proc is not None and child.proc.wait(timeout=60) == 0  # while nobody polls
    sup.stop([])
    sup.close()
    assert sorted(p.name for p in tmp_path.glob("chatty.log*")) == ["chatty.log", "chatty.log.1", "chatty.log.2"]
    assert all(p.stat().st_size <= 100_000 for p in tmp_path.glob("chatty.log*"))
    assert child.log.path.read_text().splitlines()[-1] == "last" == child.log.last


def test_stop_goes_group_by_group_in_order(tmp_path):
    log = tmp_path / "terms.txt"
    sup = Launcher(tmp_path, events=lambda line: None)
    names = services.stop_order()
    for name in reversed(names):  # started in the opposite order: the stop order is the groups'
        sup.add(name, [sys.executable, "-c", TERM_LOG + TERM_HANDLER + READY + FOREVER, str(log), name])
    sup.start_all()
    wait_for(lambda: all(ready(c) for c in sup.children.values()))
    between: list[str] = []
    sup.stop([[n] for n in names], between=lambda group: between.append(f"after {group[0]}:{log.read_text().split()[-1]}"))
    sup.close()
    assert log.read_text().split() == names == ["navigator", "localizer", "vps", "odometry", "motor", "sim"]
    assert between == [f"after {n}:{n}" for n in names]  # each group had stopped before the next was signalled
    assert all(c.proc is not None and c.proc.returncode == 0 for c in sup.children.values())


def test_a_child_that_ignores_sigterm_is_killed_after_the_grace(tmp_path, monkeypatch):
    monkeypatch.setattr(launcher, "STOP_GRACE", 0.3)
    events: list[str] = []
    sup = Launcher(tmp_path, events=events.append)
    stubborn = sup.add("stubborn", [sys.executable, "-c", DEAF + READY + FOREVER])
    polite = sup.add("polite", [sys.executable, "-c", READY + FOREVER])
    sup.start_all()
    wait_for(lambda: ready(stubborn) and ready(polite))
    sup.stop([["stubborn"]])  # `polite`, in no group, stops last
    sup.close()
    assert stubborn.proc is not None and stubborn.proc.returncode == -signal.SIGKILL
    assert polite.proc is not None and polite.proc.returncode == -signal.SIGTERM
    assert events == ["stubborn did not stop in 0.3 s: killed"]
    sup.poll()  # stopping: nothing is restarted
    assert stubborn.restarts == 0


def test_without_restart_an_exit_is_reported_with_the_log(tmp_path):
    sup = Launcher(tmp_path, restart=False, events=lambda line: None)
    child = sup.add("r1-odometry", [sys.executable, "-c", "import sys; print('no config', flush=True); sys.exit(2)"])
    alive = sup.add("r1-sim", [sys.executable, "-c", READY + FOREVER])
    sup.start_all()
    assert child.proc is not None
    child.proc.wait(timeout=20)
    sup.poll()
    assert child.restart_at is None  # not restarted
    with pytest.raises(RuntimeError, match="r1-odometry exit code 2:\nno config"):
        sup.check()
    assert set(sup.sample()) == {"r1-sim"} and sup.sample()["r1-sim"].rss > 0
    assert Path(tmp_path / "r1-sim.log") == alive.log.path
    sup.stop([])
    sup.close()
    assert alive.proc is not None and alive.proc.returncode == -signal.SIGTERM


def test_read_proc_sees_a_process_work():
    before = read_proc(os.getpid())
    sum(i * i for i in range(2_000_000))  # burn some CPU
    after = read_proc(os.getpid())
    assert after.cpu > before.cpu
    assert 10 * 2**20 < after.rss < 10 * 2**30


@pytest.mark.skipif(not os.path.exists("/proc/self/schedstat"), reason="the kernel keeps no schedstat")
def test_read_proc_counts_the_times_a_thread_got_a_core():
    before = read_proc(os.getpid())
    for _ in range(5):
        time.sleep(0.001)  # each sleep gives the core up, and the thread gets one again to go on
    after = read_proc(os.getpid())
    assert after.runs >= before.runs + 5
    assert after.waited >= before.waited


def test_a_proc_stack_without_robots_is_its_router_process(tmp_path):
    with ProcStack((), (), tmp_path) as stack:  # returns once the router listens
        with Client("r1", stack.endpoint, connect_timeout=60.0) as client:
            assert client.robot == "r1"
        assert set(stack.sample()) == {ProcStack.ROUTER}
    router = stack.launcher.children["router"]
    assert router.proc is not None and router.proc.returncode == 0, router.log.read_text()  # SIGTERM: a clean stop
