"""The serial link to a ROSArduinoBridge board: one command, one reply line, bounded in time."""

from __future__ import annotations

import os
import select
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, TypeVar

from zenav.common import extras
from zenav.services.driver import protocol as p

if TYPE_CHECKING:
    import serial

T = TypeVar("T")
READ_SIZE = 4096  # [bytes] read at once: more than a tty holds between two looks
DISCARD_READS = 16  # reads of stray bytes before a command, at most (a port that streams them: the rest count next time)


class LinkLost(Exception):
    """The port cannot be opened, vanished (cable pulled) or failed: close it and reopen later."""


class NoReply(Exception):
    """No complete reply line within the reply timeout."""


class Board:
    """A board on a serial port: `ask` writes a command and returns its reply line.

    The protocol is strict request-reply, so bytes waiting before a command are stray
    (a late reply, noise): they are read away and counted in `garbage` first. pyserial
    opens and sets up the port (non-blocking, a read returning at once); the exchanges
    use its file descriptor directly: a write, then a select and a read for each chunk
    of the reply, where pyserial's calls add a select and a size query around each.
    """

    def __init__(self, port: str, baud: int, timeout: float) -> None:
        self.port, self.baud = port, baud
        self.timeout = timeout  # [s] for one reply
        self.garbage = 0  # [bytes] stray or unparsable bytes read away so far
        self._serial = extras.require("serial", "the driver (the motor board's serial link)")  # pyserial
        self._ser: serial.Serial | None = None
        self._lines = p.Lines()

    @property
    def is_open(self) -> bool:
        return self._ser is not None

    def open(self) -> None:
        """Open the port (LinkLost if it is not there)."""
        self.close()
        try:
            self._ser = self._serial.Serial(self.port, self.baud, timeout=0, write_timeout=self.timeout, exclusive=True)
        except (self._serial.SerialException, OSError, ValueError) as e:
            raise LinkLost(f"cannot open {self.port}: {e}") from None
        self._lines.clear()

    def close(self) -> None:
        """Close the port if open (errors of a vanished device are ignored)."""
        ser, self._ser = self._ser, None
        if ser is not None:
            try:
                ser.close()
            except (self._serial.SerialException, OSError):
                pass

    def ask(self, cmd: bytes) -> str:
        """Send one command and return its reply line (NoReply, LinkLost)."""
        fd = self._fd()
        try:
            self._discard(fd)
            self._write(fd, cmd)
            return self._read_line(fd, time.monotonic() + self.timeout)
        except OSError as e:
            self.close()
            raise LinkLost(f"{self.port}: {e}") from None

    def resync(self) -> None:
        """Clear the board's half-parsed command with a bare CR, then read its answer away."""
        fd = self._fd()
        try:
            self._discard(fd)
            self._write(fd, b"\r")
            try:
                line = self._read_line(fd, time.monotonic() + self.timeout)
                if line != p.INVALID:  # the firmware's answer to a bare CR; anything else is stray
                    self.garbage += len(line)
            except NoReply:
                pass
            self._lines.clear()
        except OSError as e:
            self.close()
            raise LinkLost(f"{self.port}: {e}") from None

    # ------------------------------------------------------------ commands
    def encoders(self) -> tuple[int, int]:
        """`e`: the cumulative counts (left, right) [ticks]."""
        return self._call(p.read_encoders(), p.parse_encoders)

    def speeds(self, left: int, right: int) -> None:
        """`m L R`: target speeds [ticks per PID frame]."""
        self._call(p.motor_speeds(left, right), p.parse_ok)

    def reset(self) -> None:
        """`r`: counts to 0."""
        self._call(p.reset_encoders(), p.parse_ok)

    def get_baud(self) -> int:
        """`b`: the baud rate the firmware was built with."""
        return self._call(p.get_baud(), p.parse_int)

    def set_pid(self, kp: int, kd: int, ki: int, ko: int) -> None:
        """`u Kp:Kd:Ki:Ko`: the PID gains."""
        self._call(p.update_pid(kp, kd, ki, ko), p.parse_ok)

    # ------------------------------------------------------------ internals
    def _call(self, cmd: bytes, parse: Callable[[str], T]) -> T:
        """Ask, then parse the reply; a reply that does not parse counts as garbage (BadReply)."""
        line = self.ask(cmd)
        try:
            return parse(line)
        except p.BadReply:
            self.garbage += len(line)
            raise

    def _fd(self) -> int:
        if self._ser is None:
            raise LinkLost(f"{self.port} is not open")
        return int(self._ser.fileno())

    def _discard(self, fd: int) -> None:
        """Read away whatever waits; count all but whitespace as garbage."""
        for _ in range(DISCARD_READS):
            data = _read(fd)
            if not data:
                break
            self.garbage += len(data.strip())
        self._lines.clear()
        self.garbage += self._lines.dropped
        self._lines.dropped = 0

    def _write(self, fd: int, data: bytes) -> None:
        """All of `data`, waiting for room in the port's buffer at most the reply timeout (OSError then)."""
        deadline = time.monotonic() + self.timeout
        while data:
            try:
                data = data[os.write(fd, data) :]
            except BlockingIOError:
                pass
            if data and not select.select([], [fd], [], max(deadline - time.monotonic(), 0.0))[1]:
                raise OSError(f"write timed out after {self.timeout * 1e3:.0f} ms")

    def _read_line(self, fd: int, deadline: float) -> str:
        """The next complete non-empty line before `deadline` (monotonic [s]); earlier lines count as garbage."""
        while True:
            left = deadline - time.monotonic()
            if left <= 0.0:
                raise NoReply(f"no reply within {self.timeout * 1e3:.0f} ms")
            if not select.select([fd], [], [], left)[0]:
                continue
            data = _read(fd)
            if data is None:
                continue  # readable a moment ago, not now
            if not data:
                raise OSError("the port is readable but returns nothing (unplugged?)")
            lines = self._lines.feed(data)
            if lines:
                self.garbage += sum(len(line) for line in lines[:-1])
                return lines[-1]


def _read(fd: int) -> bytes | None:
    """What the port holds now: b"" when nothing (pyserial sets the tty to return at once), None when a
    non-blocking read would wait."""
    try:
        return os.read(fd, READ_SIZE)
    except BlockingIOError:
        return None
