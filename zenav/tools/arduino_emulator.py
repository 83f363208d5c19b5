"""A ROSArduinoBridge board on a pseudo-terminal: try the driver with no hardware.

    python -m zenav.tools.arduino_emulator --link /tmp/zenav-board   # then [driver] port = "/tmp/zenav-board"

The board's loop as its firmware runs it: the command parser (one letter, arguments
split by spaces, run on CR), the PID at PID_RATE with the firmware's integer maths and
default gains, the auto-stop after AUTO_STOP_INTERVAL without `m`/`o`, replies delayed
by their bytes' time on the wire at the baud rate (garbage if the port's baud is not
the board's). Each wheel is a first-order motor (speed proportional to PWM, time
constant `tau`). Faults on demand: `garbage(bytes)`, `unplug()`, `replug()`. `link` is
a symlink to the pty's slave, re-pointed on re-plug, like /dev/serial/by-id/.
"""

from __future__ import annotations

import argparse
import math
import os
import select
import termios
import threading
import time
import tty
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from zenav.services.driver import protocol as p

GAINS = (20, 12, 0, 50)  # the firmware's Kp, Kd, Ki, Ko
BITS_PER_BYTE = 10  # start + 8 data + stop
REQUEST_WAIT = 2.0  # [s] a fault request waits this long for the board's loop to take it


def _cdiv(a: int, b: int) -> int:
    """C integer division: truncates toward zero."""
    q = abs(a) // abs(b)
    return q if (a >= 0) == (b > 0) else -q


def _atoi(text: str) -> int:
    """C atoi: optional sign, then digits up to the first other character; 0 if none."""
    s = text.lstrip(" ")
    sign, i = (-1, 1) if s[:1] == "-" else (1, 1 if s[:1] == "+" else 0)
    j = i
    while j < len(s) and s[j].isdigit():
        j += 1
    return sign * int(s[i:j]) if j > i else 0


@dataclass
class Wheel:
    """One motor, its encoder and its PID state (the firmware's SetPointInfo)."""

    pos: float = 0.0  # [ticks] encoder position (the count is its floor)
    speed: float = 0.0  # [ticks/s]
    pwm: int = 0  # -255..255
    target: int = 0  # [ticks/frame]
    prev_enc: int = 0
    prev_input: int = 0
    iterm: int = 0
    output: int = 0

    @property
    def count(self) -> int:
        return p.wrap32(math.floor(self.pos))

    def advance(self, dt: float, gain: float, tau: float) -> None:
        """`dt` [s] of the first-order motor at a constant PWM (exact)."""
        final = gain * self.pwm
        decay = math.exp(-dt / tau)
        self.pos += final * dt + (self.speed - final) * tau * (1.0 - decay)
        self.speed = final + (self.speed - final) * decay

    def reset_pid(self) -> None:
        self.target, self.prev_enc, self.prev_input, self.iterm, self.output = 0, self.count, 0, 0, 0

    def pid(self, gains: tuple[int, int, int, int]) -> None:
        """One PID frame (doPID)."""
        kp, kd, ki, ko = gains
        enc = self.count
        inp = p.wrap32(enc - self.prev_enc)
        err = self.target - inp
        out = _cdiv(kp * err - kd * (inp - self.prev_input) + self.iterm, ko or 1) + self.output
        if out >= p.MAX_PWM:
            out = p.MAX_PWM
        elif out <= -p.MAX_PWM:
            out = -p.MAX_PWM
        else:
            self.iterm += ki * err
        self.prev_enc, self.output, self.prev_input = enc, out, inp


@dataclass
class Board:
    """The firmware's state: parser, wheels, PID, auto-stop (times on the host's monotonic clock [s])."""

    baud: int
    pid_rate: float
    auto_stop: float
    gains: tuple[int, int, int, int] = GAINS
    wheels: tuple[Wheel, Wheel] = field(default_factory=lambda: (Wheel(), Wheel()))
    moving: bool = False
    last_motor: float | None = None  # [s] time of the last m/o
    cmd: str = ""
    args: list[str] = field(default_factory=lambda: [""])  # the command letter's arguments as typed

    def reset_pid(self) -> None:
        for w in self.wheels:
            w.reset_pid()

    def set_pwm(self, left: int, right: int) -> None:
        for w, v in zip(self.wheels, (left, right)):
            w.pwm = max(-p.MAX_PWM, min(p.MAX_PWM, v))

    def frame(self) -> None:
        """updatePID: one PID frame."""
        if not self.moving:
            if any(w.prev_input for w in self.wheels):
                self.reset_pid()
            return
        self.wheels[1].pid(self.gains)
        self.wheels[0].pid(self.gains)
        self.set_pwm(self.wheels[0].output, self.wheels[1].output)

    def char(self, c: str, now: float) -> tuple[str, str] | None:
        """One received character; (the command as parsed, its reply as sent) when it ends a command."""
        if c == "\r":
            typed = " ".join([self.cmd, *self.args[1:]]).strip()
            reply = self.run(now) + "\r\n"
            if self.cmd == p.READ_ENCODERS:
                reply += "\n"  # the firmware prints a newline after the counts' line
            self.cmd, self.args = "", [""]
            return typed, reply
        if c == " ":
            if len(self.args) < 3:
                self.args.append("")
            return None
        if len(self.args) == 1:
            self.cmd = c
        elif len(self.args[-1]) < 15:  # argv1/argv2 hold 16 chars
            self.args[-1] += c
        return None

    def run(self, now: float) -> str:
        """runCommand: the reply to the parsed command."""
        a1 = _atoi(self.args[1]) if len(self.args) > 1 else 0
        a2 = _atoi(self.args[2]) if len(self.args) > 2 else 0
        left, right = self.wheels
        if self.cmd == p.GET_BAUDRATE:
            return str(self.baud)
        if self.cmd == p.READ_ENCODERS:
            return f"{left.count} {right.count}"
        if self.cmd == p.RESET_ENCODERS:
            for w in self.wheels:
                w.pos = 0.0
            self.reset_pid()
            return p.OK
        if self.cmd == p.MOTOR_SPEEDS:
            self.last_motor = now
            if a1 == 0 and a2 == 0:
                self.set_pwm(0, 0)
                self.reset_pid()
                self.moving = False
            else:
                self.moving = True
            left.target, right.target = a1, a2
            return p.OK
        if self.cmd == p.MOTOR_RAW_PWM:
            self.last_motor = now
            self.reset_pid()
            self.moving = False
            self.set_pwm(a1, a2)
            return p.OK
        if self.cmd == p.UPDATE_PID:
            parts = [_atoi(x) for x in (self.args[1] if len(self.args) > 1 else "").split(":")][:4]
            self.gains = (*parts, *self.gains[len(parts) :])  # type: ignore[assignment]
            return p.OK
        return p.INVALID


class Emulator:
    """The board behind a pty, its loop in a thread; `link` points at the pty's slave."""

    def __init__(
        self,
        link: str,
        *,
        baud: int = p.BAUD,
        ticks_per_rev: int = 360,
        pid_rate: float = p.PID_RATE,
        max_speed: float = 15.0,  # [rad/s] of a wheel at full PWM
        tau: float = 0.05,  # [s] the motor's time constant
        auto_stop: float = p.AUTO_STOP,
        wire_time: bool = True,  # replies take their bytes' time at the baud rate
    ) -> None:
        self.link = link
        self.board = Board(baud, pid_rate, auto_stop)
        self.gain = max_speed * ticks_per_rev / (2.0 * math.pi) / p.MAX_PWM  # [ticks/s per PWM step]
        self.tau, self.wire_time = tau, wire_time
        self.commands: list[tuple[float, str]] = []  # (monotonic time [s], command) every command received
        self.auto_stops = 0  # times the firmware's auto-stop stopped moving wheels
        self.plugged = False
        self._cond = threading.Condition()
        self._requests: list[Callable[[], None]] = []
        self._master: int | None = None
        self._slave: int | None = None
        self._out: list[tuple[float, bytes]] = []  # (due time, bytes) to write
        self._wake_r, self._wake_w = os.pipe()
        self._stop = False
        self._t = time.monotonic()  # [s] the physics' time
        self._next_frame = self._t
        self._thread = threading.Thread(target=self._loop, name="arduino-emulator", daemon=True)

    # ------------------------------------------------------------ control
    def start(self) -> Emulator:
        """Plug the board in and start its loop."""
        self._plug()
        self._thread.start()
        return self

    def close(self) -> None:
        """Stop the loop, unplug, remove the link."""
        self._stop = True
        os.write(self._wake_w, b"x")
        self._thread.join(timeout=REQUEST_WAIT)
        self._unplug()
        for fd in (self._wake_r, self._wake_w):
            os.close(fd)

    def __enter__(self) -> Emulator:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    def garbage(self, data: bytes) -> None:
        """Send `data` unasked, as noise on the line would."""
        self._request(lambda: self._out.append((time.monotonic(), data)))

    def unplug(self) -> None:
        """Pull the cable: the pty closes (the driver's reads fail) and the link goes; the board keeps running."""
        self._request(self._unplug)

    def replug(self, reset: bool = True) -> None:
        """Plug the cable back in: a new pty behind the same link; `reset`: the board restarts (counts 0)."""

        def plug() -> None:
            if reset:
                self.board = Board(self.board.baud, self.board.pid_rate, self.board.auto_stop)
            self._plug()

        self._request(plug)

    def brownout(self) -> None:
        """The board restarts on the same link (a brown-out, a watchdog reset): counts 0, wheels stopped."""

        def restart() -> None:
            self.board = Board(self.board.baud, self.board.pid_rate, self.board.auto_stop)

        self._request(restart)

    def counts(self) -> tuple[int, int]:
        """The encoder counts the board would answer now."""
        with self._cond:
            self._advance(time.monotonic())
            return self.board.wheels[0].count, self.board.wheels[1].count

    def pwm(self) -> tuple[int, int]:
        """The PWM the motors run at now."""
        with self._cond:
            return self.board.wheels[0].pwm, self.board.wheels[1].pwm

    def wait(self, pred: Callable[[], bool], timeout: float) -> bool:
        """Wait until `pred()` (checked after every command and PID frame) or `timeout` [s]; its last value."""
        with self._cond:
            return self._cond.wait_for(pred, timeout)

    # ------------------------------------------------------------ the board's loop
    def _request(self, fn: Callable[[], None]) -> None:
        done = threading.Event()

        def run() -> None:
            fn()
            done.set()

        with self._cond:
            self._requests.append(run)
        os.write(self._wake_w, b"x")
        if not done.wait(REQUEST_WAIT):
            raise TimeoutError("the emulator's loop did not take the request")

    def _plug(self) -> None:
        master, slave = os.openpty()
        tty.setraw(slave)
        termios.tcsetattr(slave, termios.TCSANOW, self._speed_attrs(slave, self.board.baud))
        os.set_blocking(master, False)
        tmp = f"{self.link}.{os.getpid()}.tmp"
        if os.path.lexists(tmp):
            os.unlink(tmp)
        os.symlink(os.ttyname(slave), tmp)
        os.replace(tmp, self.link)  # atomically re-pointed
        self._master, self._slave, self._out, self.plugged = master, slave, [], True

    def _unplug(self) -> None:
        for fd in (self._master, self._slave):
            if fd is not None:
                os.close(fd)
        self._master = self._slave = None
        self.plugged = False
        if os.path.lexists(self.link):
            os.unlink(self.link)

    @staticmethod
    def _speed_attrs(fd: int, baud: int) -> list[Any]:
        attrs = termios.tcgetattr(fd)
        speed = getattr(termios, f"B{baud}", termios.B57600)
        attrs[4] = attrs[5] = speed
        return attrs

    def _baud_matches(self) -> bool:
        """Whether the port is set to the board's baud (the driver opened it right)."""
        if self._slave is None:
            return False
        speed = termios.tcgetattr(self._slave)[5]
        return bool(speed == getattr(termios, f"B{self.board.baud}", None))

    def _loop(self) -> None:
        while not self._stop:
            with self._cond:
                now = time.monotonic()
                self._advance(now)
                for run in self._requests:
                    run()
                self._requests.clear()
                self._flush(now)
                due = min([self._next_frame, *(t for t, _ in self._out)])
                fds = [self._wake_r] + ([self._master] if self._master is not None else [])
            ready, _, _ = select.select(fds, [], [], max(0.0, min(due - time.monotonic(), 0.1)))
            if self._wake_r in ready:
                os.read(self._wake_r, 64)
            if self._master is not None and self._master in ready:
                self._receive()

    def _receive(self) -> None:
        assert self._master is not None
        try:
            data = os.read(self._master, 256)
        except (BlockingIOError, OSError):
            return
        with self._cond:
            now = time.monotonic()
            self._advance(now)
            for c in data.decode("latin-1"):
                done = self.board.char(c, now)
                if done is None:
                    continue
                self.commands.append((now, done[0]))
                out = done[1].encode("ascii")
                if not self._baud_matches():
                    out = bytes(b ^ 0x5A for b in out)  # what a wrong baud rate reads as
                delay = (len(out) + 2) * BITS_PER_BYTE / self.board.baud if self.wire_time else 0.0
                self._out.append((now + delay, out))
            self._cond.notify_all()

    def _flush(self, now: float) -> None:
        """Write the replies that are due."""
        due = [o for o in self._out if o[0] <= now]
        self._out = [o for o in self._out if o[0] > now]
        for _, data in due:
            if self._master is not None:
                try:
                    os.write(self._master, data)
                except OSError:  # nobody reads (queue full or no one there): lost, as on a UART
                    pass

    def _advance(self, now: float) -> None:
        """Run the physics and the firmware's loop up to `now` (frame by frame)."""
        b = self.board
        while self._t < now:
            step_end = min(now, self._next_frame)
            for w in b.wheels:
                w.advance(step_end - self._t, self.gain, self.tau)
            self._t = step_end
            if self._t >= self._next_frame:
                b.frame()
                self._next_frame += 1.0 / b.pid_rate
                self._cond.notify_all()
        if b.last_motor is not None and now - b.last_motor > b.auto_stop:
            if any(w.pwm for w in b.wheels) or b.moving:
                self.auto_stops += 1
            b.set_pwm(0, 0)
            b.moving = False
            b.last_motor = None


def main(argv: list[str] | None = None) -> int:
    """Run an emulated board until Ctrl-C."""
    parser = argparse.ArgumentParser(prog="arduino_emulator", description=__doc__.splitlines()[0])
    parser.add_argument("--link", default="/tmp/zenav-board", help="path of the symlink to the pty (the driver's port)")
    parser.add_argument("--baud", type=int, default=p.BAUD)
    parser.add_argument("--ticks-per-rev", type=int, default=360)
    parser.add_argument("--pid-rate", type=float, default=p.PID_RATE)
    args = parser.parse_args(argv)
    with Emulator(args.link, baud=args.baud, ticks_per_rev=args.ticks_per_rev, pid_rate=args.pid_rate) as emu:
        print(f"board on {os.path.realpath(args.link)}, linked at {args.link}; Ctrl-C to stop", flush=True)
        try:
            threading.Event().wait()
        except KeyboardInterrupt:
            pass
        print(f"{len(emu.commands)} commands, counts {emu.counts()}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
