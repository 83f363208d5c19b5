"""The driver and the odometry on a real router, the board emulated on a pty: drive, noise, unplug, stop."""

from __future__ import annotations

import threading
import time

import pytest

from zenav.common import messages as m
from zenav.common.bus import ZenohBus
from zenav.common.client import Client
from zenav.common.config import Settings
from zenav.common.runtime import Service
from zenav.services.driver.board import Board
from zenav.services.driver.service import Driver
from zenav.services.odometry.service import Odometry
from zenav.tools.arduino_emulator import Emulator

WAIT = 5.0  # [s] longest wait for one condition
COMMAND_PERIOD = 0.05  # [s] motors/wheels at 20 Hz, as the motor service sends them


class Running:
    """A service on its own session and worker thread, with the clock it picks itself."""

    def __init__(self, cls: type[Service], settings: Settings, router: str) -> None:
        self.bus = ZenohBus.open(router)
        self.svc = cls(settings, self.bus, cls.make_clock(settings))
        self.svc.start()
        self.thread = threading.Thread(target=self.svc.run, daemon=True)
        self.thread.start()

    def close(self) -> None:
        self.svc.stop()
        self.thread.join(timeout=WAIT)
        self.svc.close()
        self.bus.close()


class Commander:
    """Publishes one wheel command at 20 Hz from its own thread until stopped."""

    def __init__(self, client: Client, left: float, right: float) -> None:
        self.client, self.cmd = client, (left, right)
        self.done = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        while not self.done.wait(COMMAND_PERIOD):  # the pace of a command stream, not a synchronisation
            self.client.publish("motors/wheels", m.Wheels(t=0.0, left=self.cmd[0], right=self.cmd[1]))

    def stop(self) -> None:
        self.done.set()
        self.thread.join(timeout=WAIT)


@pytest.fixture
def rig(tmp_path, router):
    settings = Settings.load(
        None,
        deployment={"clock": "wall"},
        driver={"port": str(tmp_path / "board"), "open_delay": 0.0, "reply_timeout": 0.2, "reconnect_period": 0.2},
        odometry={"heading_source": "encoders"},
    )
    with Emulator(str(tmp_path / "board")) as emu, Client("r1", router) as client:
        services = [Running(Odometry, settings, router), Running(Driver, settings, router)]
        try:
            yield emu, client, services[1].svc
        finally:
            for s in reversed(services):
                s.close()


def test_drive_noise_unplug_replug_and_the_watchdog_stop(rig):
    emu, client, driver = rig
    encoders, odom = client.latest("sensors/encoders"), client.latest("odom")
    diag = []
    client.subscribe("diag/driver", diag.append, typ=m.Diag)
    assert encoders.wait(timeout=WAIT) is not None

    # A wheels command turns the emulated wheels; the counts published follow the board's.
    drive = Commander(client, 6.0, 6.0)
    try:
        assert emu.wait(lambda: emu.counts()[0] > 100, WAIT)
        truth = emu.counts()
        got = encoders.wait(lambda e: e.left >= truth[0], timeout=WAIT)
        assert got is not None and got.left <= emu.counts()[0] and abs(got.right - got.left) < 0.2 * got.left
        assert odom.wait(lambda o: o.x > 0.02, timeout=WAIT) is not None  # nothing downstream changed

        # Noise on the line: counted, and the counts keep coming.
        emu.garbage(b"\x13\xfe#garbage\r\nmore")
        assert emu.wait(lambda: driver.counters.values["garbage_bytes"] > 0, WAIT)
        now = emu.counts()
        assert encoders.wait(lambda e: e.left > now[0], timeout=WAIT) is not None

        # The cable is pulled mid-drive: diag says error, nothing crashes; plugged back, the counts flow again.
        emu.unplug()
        assert emu.wait(lambda: any(d.status == "error" and "disconnected" in d.message for d in diag), WAIT)
        held = encoders.wait(timeout=WAIT)
        emu.replug(reset=True)
        assert emu.wait(lambda: driver.counters.values["reconnects"] == 1, WAIT)
        back = encoders.wait(lambda e: e.left > held.left + 20, timeout=WAIT)
        assert back is not None  # driving again from where the counts were, not from 0
        assert emu.wait(lambda: diag[-1].status == "ok", WAIT)
    finally:
        drive.stop()

    # The commands stop: the driver stops the board well before the firmware's own 2 s auto-stop.
    t_last = time.monotonic()  # the last command was published before this

    def stopped_at() -> float | None:
        return next((t for t, c in emu.commands if c == "m 0 0" and t > t_last - COMMAND_PERIOD), None)

    assert emu.wait(lambda: stopped_at() is not None, WAIT)
    assert stopped_at() - t_last < 1.2  # [driver] command_timeout 0.5 s (a loaded host adds to it), not the firmware's 2 s
    assert emu.wait(lambda: emu.pwm() == (0, 0), WAIT)
    assert emu.auto_stops == 0 and driver.counters.values["watchdog_stops"] >= 1  # more if the host stalled the commands


def test_the_emulated_firmware_stops_by_itself_after_two_seconds(tmp_path):
    """What the driver's resends keep from happening: no `m` for AUTO_STOP_INTERVAL and the board stops the wheels."""
    with Emulator(str(tmp_path / "board")) as emu:
        board = Board(emu.link, emu.board.baud, 0.5)
        board.open()
        try:
            board.speeds(10, 10)
            t_cmd = time.monotonic()
            assert emu.wait(lambda: emu.pwm()[0] > 0, WAIT)
            assert emu.wait(lambda: emu.auto_stops == 1, WAIT)
            assert 2.0 < time.monotonic() - t_cmd < 2.0 + 0.5 and emu.pwm() == (0, 0)
        finally:
            board.close()
