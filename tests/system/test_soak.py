"""Soak: the whole stack (`zenav up --demo`: the square driven goal after goal) at
100 Hz for a while, watching what grows.

CI runs the short variant (60 s of stack time); `./run test -m slow tests/system/test_soak.py`
runs the 30-minute one. Each prints a table of resident memory per service, queue
depth, drops and goals, which docs/reliability.md quotes.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from tests.support.procs import Stack, service_pid
from zenav.services import NAMES

pytestmark = pytest.mark.system

SHORT = float(os.environ.get("ZENAV_SOAK_S", "60"))  # [s] stack time of the CI variant
SAMPLES = 10  # memory and diag readings over the run
WARMUP = 0.2  # fraction of the run before the baseline reading (imports, caches, first goals)


def rss_mb(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024.0
    raise LookupError(pid)


@pytest.mark.parametrize(
    "seconds",
    [pytest.param(SHORT, id="short"), pytest.param(1800.0, id="30min", marks=[pytest.mark.slow, pytest.mark.timeout(2700)])],
)
def test_soak(tmp_path, seconds):
    stack = Stack(tmp_path, ["--demo"], duration=2 * seconds + 300)
    c = stack.client
    ends: list = []
    c.subscribe("nav/state", lambda s: s.result is not None and ends.append((s.goal_id, s.result, s.message)))
    diags = {s: c.latest(f"diag/{s}") for s in NAMES}
    try:
        c.wait_alive(NAMES, timeout=90)
        pids = {s: service_pid(s, stack.endpoint) for s in NAMES}
        t0 = stack.truth.wait(timeout=30).t
        readings = []  # (t, {service: rss MB}, {service: queue})
        for k in range(SAMPLES + 1):
            at = t0 + seconds * (WARMUP + (1.0 - WARMUP) * k / SAMPLES)
            tr = stack.truth.wait(lambda t, at=at: t.t >= at, timeout=seconds * 3 + 60)
            queues = {s: diags[s].wait(timeout=10).queue for s in NAMES}
            readings.append((tr.t, {s: rss_mb(pids[s]) for s in NAMES}, queues))
        final = {s: diags[s].wait(lambda d, at=readings[-1][0]: d.t >= at, timeout=10) for s in NAMES}
        assert {s: service_pid(s, stack.endpoint) for s in NAMES} == pids  # nothing restarted
    finally:
        print(stack.close()[-2000:])

    base, last = readings[0][1], readings[-1][1]
    cmds = final["motor"].counters.get("msgs_in", 0)
    print(f"\nsoak {seconds:.0f} s of stack time, {len(ends)} goals ended")
    print("| service | RSS at 20 % MB | RSS at end MB | growth MB | max queue | dropped_overflow | bad_input |")
    print("|---|---|---|---|---|---|---|")
    for s in NAMES:
        q = max(r[2][s] for r in readings)
        cnt = final[s].counters
        print(
            f"| {s} | {base[s]:.1f} | {last[s]:.1f} | {last[s] - base[s]:+.1f} | {q} "
            f"| {cnt.get('dropped_overflow', 0)} | {cnt.get('bad_input', 0)} |"
        )
    stale = final["motor"].counters.get("dropped_stale", 0)
    print(f"motor: {cmds} cmd_vel in, {stale} dropped stale, {final['motor'].counters.get('watchdog_stops', 0)} watchdog stops")

    results = [r for _, r, _ in ends]
    assert results.count("succeeded") >= seconds / 30, ends  # the demo's goals kept ending well
    assert "aborted" not in results, ends
    for s in NAMES:
        assert final[s].counters.get("dropped_overflow", 0) == 0, s  # no queue ever overflowed
        assert final[s].counters.get("bad_input", 0) == 0, s
        assert max(r[2][s] for r in readings[len(readings) // 2 :]) < 100, s  # no queue builds up
        assert last[s] - base[s] < max(5.0, 0.1 * base[s]), f"{s}: {base[s]:.1f} -> {last[s]:.1f} MB"
    assert stale <= 0.001 * cmds  # control messages arrive in time
