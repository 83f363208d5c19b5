"""`zenav record` killed, hung up or closed: what is on disk is readable, and `zenav plot`/`replay` read it."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from mcap.reader import make_reader

from tests.support.matching import wait_subscriber
from tests.support.procs import reaped, stderr_lines
from zenav.common import codec, keys
from zenav.common import messages as m
from zenav.common.bus import ZenohBus
from zenav.tools import mcap_format as fmt
from zenav.tools.record import FLUSH_PERIOD

RATE = 100.0  # [Hz] clock messages the synthetic robot sends
SLACK = 1.0  # [s] scheduling on a loaded machine, on top of FLUSH_PERIOD


def start_recorder(router: str, out: Path) -> tuple[subprocess.Popen, object]:
    proc = subprocess.Popen([sys.executable, "-m", "zenav", "record", str(out), "--connect", router], stderr=subprocess.PIPE, text=True)
    lines = stderr_lines(proc)
    assert f"to {out}.part" in lines.get(timeout=30)
    return proc, lines


def send_run(bus: ZenohBus, seconds: float) -> list[float]:
    """Publish clock ticks and a robot driving east at RATE for `seconds` of wall time; their t, in order."""
    sent: list[float] = []
    pace = threading.Event()  # never set: its wait() paces the synthetic robot
    for i in range(int(seconds * RATE)):
        t = i / RATE
        bus.publish(keys.key("r1", "clock"), codec.encode(m.Clock(t=t)))
        bus.publish(keys.key("r1", "sim/truth"), codec.encode(m.Truth(t=t, x=0.1 * t, y=0.0, theta=0.0, v=0.1, omega=0.0)))
        bus.publish(keys.key("r1", "odom"), codec.encode(m.Odom(t=t, x=0.11 * t, y=0.0, theta=0.0, v=0.1, omega=0.0)))
        sent.append(t)
        pace.wait(1.0 / RATE)
    return sent


def run_cli(*argv: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "zenav", *argv], capture_output=True, text=True, timeout=60)


def test_a_killed_recorder_leaves_a_part_file_readable_up_to_a_second_before(router, publisher, tmp_path):
    out = tmp_path / "run.mcap"
    proc, _ = start_recorder(router, out)
    with reaped(proc):
        wait_subscriber(publisher, keys.key("r1", "clock"))
        sent = send_run(publisher, 3.0)
        killed_at = time.monotonic()
        proc.send_signal(signal.SIGKILL)
        assert proc.wait(timeout=10) == -signal.SIGKILL
    part = Path(f"{out}.part")
    assert not out.exists() and part.exists()
    assert fmt.finished(str(part)) is False
    got = [r.msg.t for r in fmt.read(str(part), "r1", ["clock"])]
    assert got == sent[: len(got)]  # in order, none missing, nothing made up
    lost = (len(sent) - len(got)) / RATE  # [s] of messages before the kill
    assert lost <= FLUSH_PERIOD + SLACK, f"{lost:.2f} s lost ({len(got)} of {len(sent)} kept)"
    assert time.monotonic() - killed_at < 30
    assert fmt.robots(str(part)) == ["r1"]

    # zenav plot and zenav replay take it, and say it was not closed cleanly
    plotted = run_cli("plot", str(part), "-o", str(tmp_path / "run.png"))
    assert plotted.returncode == 0 and "not closed cleanly" in plotted.stderr, plotted.stderr
    assert "odom   rms" in plotted.stdout and (tmp_path / "run.png").read_bytes()[:4] == b"\x89PNG"
    replayed = run_cli("replay", str(part), "--connect", router, "--rate", "0", "--topics", "clock")
    assert replayed.returncode == 0, replayed.stderr
    assert "not closed cleanly" in replayed.stderr and f"{len(got)} messages replayed" in replayed.stderr
    # asked for the finished name, they point at the .part
    missing = run_cli("replay", str(out), "--connect", router)
    assert missing.returncode == 2 and f"{part} is there" in missing.stderr


@pytest.mark.parametrize("sig", [signal.SIGHUP, signal.SIGTERM])
def test_a_hangup_or_terminate_finishes_the_file(router, publisher, tmp_path, sig):
    out = tmp_path / "run.mcap"
    proc, lines = start_recorder(router, out)
    with reaped(proc):
        wait_subscriber(publisher, keys.key("r1", "clock"))
        sent = [i * 0.01 for i in range(300)]
        for t in sent:
            publisher.publish(keys.key("r1", "clock"), codec.encode(m.Clock(t=t)))
        proc.send_signal(sig)
        assert proc.wait(timeout=30) == 0
    assert "300 messages on 1 topics" in lines.get(timeout=10)
    assert out.exists() and not os.path.exists(f"{out}.part")
    assert fmt.finished(str(out))
    with open(out, "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None  # indexed: Foxglove opens it at once
    assert [r.msg.t for r in fmt.read(str(out), "r1", ["clock"])] == sent
