"""py-spy on real processes: a running interpreter sampled from outside, without stopping it."""

from __future__ import annotations

import subprocess
import sys

import pytest

from zenav.bench import spy

# A thread named "spinner" that keeps one known function busy for the test's length (bounded: it ends by itself).
BUSY = """\
import threading, time
def spin_here(until):
    while time.monotonic() < until:
        sum(range(200))
t = threading.Thread(target=spin_here, args=(time.monotonic() + 60.0,), name="spinner")
t.start()
print("up", flush=True)
t.join()
"""


def test_a_busy_thread_is_sampled_by_its_name_and_function():
    why = spy.refused()
    if why is not None:
        pytest.skip(why)
    proc = subprocess.Popen([sys.executable, "-c", BUSY], stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout is not None and proc.stdout.readline().strip() == "up"
        got = spy.record({"busy": proc.pid}, seconds=1, rate=200)["busy"]
    finally:
        proc.kill()
        proc.wait()
        if proc.stdout is not None:
            proc.stdout.close()
    assert got.samples > 50  # a thread busy the whole second, 200 samples a second
    assert got.threads.most_common(1)[0][0] == "spinner"
    assert got.own.most_common(1)[0][0].startswith("spin_here (")
    assert got.samples == sum(got.own.values())


def test_a_process_that_is_gone_fails_with_pyspys_reason():
    if spy.executable() is None:
        pytest.skip("py-spy is not installed")
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    with pytest.raises(RuntimeError, match="py-spy failed: gone"):
        spy.record({"gone": proc.pid}, seconds=1)


def test_the_robot_services_are_sampled_as_deployed(tmp_path):
    why = spy.refused()
    if why is not None:
        pytest.skip(why)
    d = spy.deployed(3, tmp_path)
    assert set(d.spied) == set(d.cores) == {"odometry", "localizer", "navigator", "motor"}
    for name, s in d.spied.items():
        assert s.samples > 0 and 0.0 < d.cores[name] < 1.0, name
    # the localizer's own handler ran, on whichever thread served it; Zenoh's readers are named
    assert any(".on_odom (" in f for f in d.spied["localizer"].total)
    assert any(t.startswith("rx-") for s in d.spied.values() for t in s.threads)
    assert "\n".join(spy.lines(d)).count("as deployed") == 4  # a table of functions per service
