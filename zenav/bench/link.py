"""The driver on a serial link slower than its commands: how old the command the board runs is.

The driver service (its own worker, the wall clock, an in-memory bus) drives the emulated
ROSArduinoBridge board on a real pseudo-terminal (tools/arduino_emulator.py: replies take
their bytes' time at the baud rate), while `motors/wheels` comes as the motor sends it,
100 a second, each a new target. Per baud rate: the age of each command the board
received (from its `motors/wheels` to the board), how many the driver sent, how many a
newer one superseded, and how often the counts were read meanwhile.

`zenav bench link` prints the table for BAUDS, 5 s each.
"""

from __future__ import annotations

import os
import statistics
import tempfile
import threading
import time
from dataclasses import dataclass

from zenav.common import codec, keys
from zenav.common import messages as m
from zenav.common.bus import MemoryBus
from zenav.common.clock import WallClock
from zenav.common.config import Settings
from zenav.services.driver import protocol as p
from zenav.services.driver.service import Driver
from zenav.tools.arduino_emulator import Emulator

RATE = 100.0  # [Hz] motors/wheels, as the motor sends it
BAUDS = (57600, 9600, 4800, 2400)  # the baud rates `zenav bench link` measures
WAIT = 5.0  # [s] the longest wait for the board's handshake


@dataclass
class Link:
    baud: int
    commands: int  # motors/wheels published
    sent: int  # of them, received by the board while they came
    superseded: int  # dropped for a newer one before the driver got to them
    queued: int  # still in the driver's queue when they stopped coming
    age_p50: float  # [s] from a command's motors/wheels to the board
    age_max: float  # [s]
    reads: float  # [1/s] encoder reads published while the commands came


def target(i: int) -> tuple[int, int]:
    """Command i's target [ticks per PID frame]: every one differs from the one before, unique over 722."""
    j = (i // 19) % 38
    return i % 19 + 1, j - 19 + (j >= 19)


def run(baud: int, seconds: float) -> Link:
    """Drive the emulated board at `baud` with motors/wheels at RATE for `seconds`."""
    with tempfile.TemporaryDirectory() as tmp, Emulator(os.path.join(tmp, "board"), baud=baud) as emu:
        bus = MemoryBus()
        cfg = {"port": emu.link, "baud": baud, "open_delay": 0.0, "reply_timeout": 0.5, "command_timeout": 1.5}
        driver = Driver(Settings.load(None, driver=cfg), bus, WallClock())
        driver.start()
        worker = threading.Thread(target=driver.run, daemon=True)
        worker.start()
        try:
            if not emu.wait(lambda: driver.synced, WAIT):
                raise RuntimeError(f"the driver did not reach the emulated board at {baud} baud")
            wheels, encoders = keys.key(driver.robot, "motors/wheels"), keys.key(driver.robot, "sensors/encoders")
            published: dict[tuple[int, int], float] = {}  # target -> when its command was published
            n, start = round(seconds * RATE), time.monotonic()
            reads0 = sum(k == encoders for k, _ in bus.published)
            ticks, rate = driver.ticks_per_rev, driver.cfg.pid_rate  # the geometry the driver converts with
            for i in range(n):
                left, right = target(i)
                msg = m.Wheels(t=0.0, left=p.wheel_speed(left, ticks, rate), right=p.wheel_speed(right, ticks, rate))
                published[(left, right)] = time.monotonic()
                bus.publish(wheels, codec.encode(msg))
                time.sleep(max(start + (i + 1) / RATE - time.monotonic(), 0.0))
            end = time.monotonic()
            reads = (sum(k == encoders for k, _ in bus.published) - reads0) / (end - start)
            queued = driver._inbox.qsize()
        finally:
            driver.stop()
            worker.join(WAIT)
            driver.close()
        ages = []
        for t, command in emu.commands:
            parts = command.split(" ")
            if parts[0] == "m" and len(parts) == 3 and start <= t <= end:
                sent_at = published.get((int(parts[1]), int(parts[2])))
                if sent_at is not None:
                    ages.append(t - sent_at)
        superseded = driver.counters.values.get("dropped_superseded", 0)
        return Link(baud, n, len(ages), superseded, queued, statistics.median(ages), max(ages), reads)


def table(links: list[Link]) -> str:
    lines = [
        "| baud | commands | sent while they came | superseded | queued at the end | age p50 [ms] | age max [ms] | encoder reads [1/s] |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for x in links:
        ages = f"{1e3 * x.age_p50:.1f} | {1e3 * x.age_max:.1f}"
        lines.append(f"| {x.baud} | {x.commands} | {x.sent} | {x.superseded} | {x.queued} | {ages} | {x.reads:.0f} |")
    return "\n".join(lines)
