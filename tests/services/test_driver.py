"""The driver service on the in-memory bus, its worker on the wall clock, against the emulated board on a real pty."""

from __future__ import annotations

import math
import threading
import time

import pytest

from tests.support.rig import Rig
from zenav.common import codec, keys
from zenav.common import messages as m
from zenav.common.clock import WallClock
from zenav.services.driver.service import Driver
from zenav.tools.arduino_emulator import Emulator

FAST = {"open_delay": 0.0, "reply_timeout": 0.2, "reconnect_period": 0.2}
WAIT = 3.0  # [s] longest wait for one condition


class Live:
    """The driver service running its own worker (as in its process), on a MemoryBus, with the host clock."""

    def __init__(self, emu: Emulator, **driver: object) -> None:
        self.emu = emu
        self.rig = Rig(Driver, clock=WallClock(), driver={"port": emu.link, **FAST, **driver})
        self.svc = self.rig.svc
        self.thread = threading.Thread(target=self.svc.run, daemon=True)
        self.thread.start()

    def wheels(self, left: float, right: float) -> None:
        """Publish one motors/wheels command (the worker takes it)."""
        self.rig.bus.publish(self.rig.key("motors/wheels"), codec.encode(m.Wheels(t=self.rig.t, left=left, right=right)))

    def wait(self, pred, timeout: float = WAIT) -> bool:
        """Wait until `pred()`, checked at each of the board's commands and PID frames, at most `timeout` [s]."""
        return self.emu.wait(pred, timeout)

    def encoders(self) -> list[m.Encoders]:
        return self.rig.got("sensors/encoders")

    def counter(self, name: str) -> int:
        return self.svc.counters.values.get(name, 0)

    def close(self) -> None:
        self.svc.stop()
        self.thread.join(timeout=WAIT)
        self.rig.close()

    def __enter__(self) -> Live:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


@pytest.fixture
def emu(tmp_path):
    with Emulator(str(tmp_path / "board")) as e:
        yield e


def sent(emu: Emulator, letter: str) -> list[tuple[float, str]]:
    """(time, command) of the commands with this letter the board received."""
    return [(t, c) for t, c in emu.commands if c.split(" ")[0] == letter]


def last_m(emu: Emulator) -> str | None:
    ms = sent(emu, "m")
    return ms[-1][1] if ms else None


def test_connects_resets_and_publishes_the_counts(emu):
    with Live(emu) as live:
        assert live.wait(lambda: len(live.encoders()) >= 5)
        assert live.svc.status == "ok"
        typed = [c for _, c in emu.commands]
        assert typed[0] == "" and {"b", "m 0 0", "r"} <= set(typed[: typed.index("e")])  # CR resync, probe, stop, reset
        encs = live.encoders()
        assert all((e.left, e.right) == (0, 0) for e in encs)
        assert all(b.t > a.t for a, b in zip(encs, encs[1:]))


def test_wheel_speeds_become_ticks_per_pid_frame_rounded_and_clamped(emu):
    with Live(emu) as live:
        assert live.wait(lambda: live.svc.synced)
        live.wheels(10.0, -5.0)  # 360 ticks/rev, 30 Hz: 19.1 and -9.5 ticks per frame
        assert live.wait(lambda: last_m(emu) == "m 19 -10")
        live.wheels(500.0, 0.2)  # [robot] max_wheel_speed 10 rad/s: 20 ticks/frame at most
        assert live.wait(lambda: last_m(emu) == "m 20 0")
        assert live.wait(lambda: emu.counts()[0] > 30)  # the emulated wheels turn


def test_the_counts_published_follow_the_board(emu):
    with Live(emu) as live:
        assert live.wait(lambda: live.svc.synced)
        live.wheels(6.0, 3.0)
        assert live.wait(lambda: emu.counts()[1] > 15)
        left, right = emu.counts()
        assert live.wait(lambda: live.encoders()[-1].left >= left and live.encoders()[-1].right >= right)
        last = live.encoders()[-1]
        assert left <= last.left <= emu.counts()[0] and right <= last.right <= emu.counts()[1]


def test_each_count_carries_the_speed_the_board_ran_at(emu):
    with Live(emu) as live:
        assert live.wait(lambda: live.svc.synced)
        assert live.wait(lambda: live.encoders())
        assert (live.encoders()[-1].cmd_left, live.encoders()[-1].cmd_right) == (0.0, 0.0)  # stopped since the handshake
        live.wheels(10.0, -5.0)  # the board runs 19 and -10 ticks per 1/30 s frame
        speeds = (19 * 30 * 2 * math.pi / 360, -10 * 30 * 2 * math.pi / 360)
        assert live.wait(lambda: (live.encoders()[-1].cmd_left, live.encoders()[-1].cmd_right) == pytest.approx(speeds))


def test_a_driver_behind_its_commands_sends_the_board_the_newest(emu):
    with Live(emu) as live:
        assert live.wait(lambda: live.svc.synced)
        before = len(sent(emu, "m"))
        for i in range(1, 21):  # 20 commands at once, each a new target: faster than the serial link takes them
            live.wheels(i / 2.0, 0.0)
        assert live.wait(lambda: live.counter("msgs_in") + live.counter("dropped_superseded") == 20)
        assert live.wait(lambda: last_m(emu) == "m 19 0")  # the newest, 10 rad/s
        # Those the board had no time for were dropped, not sent late one after another.
        assert live.counter("dropped_superseded") >= 1
        assert len(sent(emu, "m")) - before < 20


def test_the_counts_keep_coming_while_commands_flood_a_slow_link(tmp_path):
    # 4800 baud: a command's reply takes 8 ms on the wire and a read's about 19: together more than
    # the 10 ms between commands, so each command sent at once would leave the counts no time.
    with Emulator(str(tmp_path / "board"), baud=4800) as slow, Live(slow, baud=4800) as live:
        assert live.wait(lambda: live.svc.synced)
        start = time.monotonic()
        for i in range(100):  # a new target every 10 ms for 1 s
            live.wheels((i % 19 + 1) / 2.0, 0.0)
            time.sleep(max(start + (i + 1) / 100.0 - time.monotonic(), 0.0))  # paced as the motor sends
        reads = [c for t, c in slow.commands if c == "e" and t >= start]
        assert len(reads) >= 5  # about 24 in 1 s; one without the read first
        assert live.wait(lambda: last_m(slow) == "m 5 0")  # the newest, 2.5 rad/s


def test_watchdog_stops_the_board_when_commands_stop(emu):
    with Live(emu) as live:
        assert live.wait(lambda: live.svc.synced)
        live.wheels(5.0, 5.0)
        assert live.wait(lambda: last_m(emu) == "m 10 10")
        t_cmd = sent(emu, "m")[-1][0]
        assert live.wait(lambda: last_m(emu) == "m 0 0")
        assert 0.45 < sent(emu, "m")[-1][0] - t_cmd < 1.0  # [driver] command_timeout 0.5 s from the wheels message (sent just before)
        assert live.counter("watchdog_stops") == 1 and emu.auto_stops == 0


def test_a_standing_command_is_sent_again_before_the_firmware_stops(emu):
    with Live(emu, command_timeout=1.5, resend_period=0.3) as live:
        assert live.wait(lambda: live.svc.synced)
        live.wheels(5.0, 5.0)  # once: only the resends keep the board going
        assert live.wait(lambda: [c for _, c in sent(emu, "m")].count("m 10 10") >= 4)
        times = [t for t, c in sent(emu, "m") if c == "m 10 10"]
        assert all(0.25 < b - a < 0.8 for a, b in zip(times, times[1:])), [b - a for a, b in zip(times, times[1:])]
        assert live.counter("resends") >= 3 and emu.auto_stops == 0


def test_stop_on_exit(emu):
    live = Live(emu)
    assert live.wait(lambda: live.svc.synced)
    live.wheels(5.0, 5.0)
    assert live.wait(lambda: last_m(emu) == "m 10 10")
    live.close()
    assert last_m(emu) == "m 0 0"


def test_garbage_on_the_line_is_counted_and_survived(emu):
    with Live(emu) as live:
        assert live.wait(lambda: live.svc.synced)
        emu.garbage(b"\x00\xffnoise\r\n")
        n = len(live.encoders())
        assert live.wait(lambda: len(live.encoders()) > n + 5)
        assert live.counter("garbage_bytes") >= 7
        assert live.svc.status == "ok"


def test_a_wrong_baud_rate_is_bad_replies_then_an_error(emu):
    with Live(emu, baud=115200, max_missed=3) as live:
        assert live.wait(lambda: live.counter("disconnects") + live.counter("timeouts") >= 4)  # garbled: no line ends
        assert live.svc.status == "error" and live.counter("garbage_bytes") > 0
        assert not live.encoders()


def test_unplug_is_an_error_and_replug_recovers_with_continuous_counts(emu):
    with Live(emu) as live:
        assert live.wait(lambda: live.svc.synced)
        live.wheels(8.0, 8.0)
        assert live.wait(lambda: live.encoders() and live.encoders()[-1].left > 20)
        emu.unplug()
        assert live.wait(lambda: live.svc.status == "error")
        assert "disconnected" in live.svc.status_message and live.counter("disconnects") == 1
        before = live.encoders()[-1]
        n = len(live.encoders())
        assert not live.wait(lambda: len(live.encoders()) > n, timeout=0.5)  # reopening fails meanwhile; nothing crashes
        emu.replug(reset=True)  # the board restarted: it counts from 0 again
        assert live.wait(lambda: len(live.encoders()) > n + 3)
        assert live.svc.status == "ok" and live.counter("reconnects") == 1
        after = live.encoders()[n]
        assert (after.left, after.right) == (before.left, before.right)  # the counts go on: no jump back to 0


def test_a_missing_port_is_an_error_not_a_crash(tmp_path):
    with Rig(Driver, t0=100.0, driver={"port": str(tmp_path / "board"), **FAST}) as rig:
        rig.run(0.5, dt=0.01)
        assert rig.svc.status == "error" and "board" in rig.svc.status_message
        assert not rig.got("sensors/encoders")


def test_pid_gains_are_sent_on_connect(emu):
    with Live(emu, pid_gains=[30, 10, 1, 40]) as live:
        assert live.wait(lambda: live.svc.synced)
        assert "u 30:10:1:40" in [c for _, c in emu.commands] and emu.board.gains == (30, 10, 1, 40)


def test_the_motor_service_gone_stops_the_board_at_once(emu):
    with Live(emu, command_timeout=1.5) as live:
        token = live.rig.bus.token(keys.alive(live.rig.robot, "motor"))
        assert live.wait(lambda: live.svc.synced)
        live.wheels(5.0, 5.0)
        assert live.wait(lambda: last_m(emu) == "m 10 10")
        t_cmd = sent(emu, "m")[-1][0]
        token.undeclare()
        assert live.wait(lambda: last_m(emu) == "m 0 0")
        assert sent(emu, "m")[-1][0] - t_cmd < 1.0 and live.counter("motor_lost_stops") == 1  # not the 1.5 s watchdog


def test_a_board_that_restarts_on_the_same_link_is_a_new_baseline_not_a_jump(emu):
    with Live(emu, command_timeout=1.5) as live:
        assert live.wait(lambda: live.svc.synced)
        live.wheels(8.0, 8.0)
        assert live.wait(lambda: live.encoders() and live.encoders()[-1].left > 100)
        emu.brownout()  # counts back to 0; the driver's commands start the wheels again
        assert live.wait(lambda: live.counter("board_resets") == 1)
        n = len(live.encoders())
        assert live.wait(lambda: len(live.encoders()) > n + 5)
        lefts = [e.left for e in live.encoders()]
        assert all(b >= a for a, b in zip(lefts, lefts[1:]))  # forward only: no jump back to 0
        assert live.counter("bad_replies") == 0  # back near 0 at once: a restart, not a corrupt reply
