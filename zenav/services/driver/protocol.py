"""The ROSArduinoBridge serial protocol: commands to bytes, reply lines to values (no I/O).

A command is one letter, then space-separated integers, ended by CR; the board answers
one line ended by CRLF (`e` adds a bare LF after it in the original firmware: empty lines
are skipped). Counts are the firmware's `long`: signed 32-bit.
"""

from __future__ import annotations

import math
import re

BAUD = 57600  # [baud] the firmware's BAUDRATE (some forks: 115200)
PID_RATE = 30.0  # [Hz] the firmware's PID_RATE: `m` speeds are ticks per 1/PID_RATE s
AUTO_STOP = 2.0  # [s] the firmware's AUTO_STOP_INTERVAL: no `m`/`o` this long and it stops the wheels
MAX_PWM = 255  # the firmware's MAX_PWM: `o` takes -255..255
MAX_LINE = 64  # [bytes] a longer reply line is garbage
INVALID = "Invalid Command"
OK = "OK"
_INT = re.compile(r"-?[0-9]{1,11}")

READ_ENCODERS, MOTOR_SPEEDS, MOTOR_RAW_PWM, RESET_ENCODERS, GET_BAUDRATE, UPDATE_PID = "e", "m", "o", "r", "b", "u"


class BadReply(ValueError):
    """A reply line that is not what the command answers."""


def command(letter: str, *args: int) -> bytes:
    """`command("m", 10, -3)` -> b"m 10 -3\\r"."""
    if len(letter) != 1 or not letter.isalpha():
        raise ValueError(f"a command is one letter, not {letter!r}")
    return " ".join([letter, *(str(int(a)) for a in args)]).encode("ascii") + b"\r"


def read_encoders() -> bytes:
    """`e`: read both cumulative encoder counts."""
    return command(READ_ENCODERS)


def motor_speeds(left: int, right: int) -> bytes:
    """`m L R`: target speeds [ticks per PID frame]; `m 0 0` stops and resets the PID."""
    return command(MOTOR_SPEEDS, left, right)


def raw_pwm(left: int, right: int) -> bytes:
    """`o L R`: raw motor PWM, -255..255, PID off (the wheels-up test)."""
    if max(abs(left), abs(right)) > MAX_PWM:
        raise ValueError(f"PWM is -{MAX_PWM}..{MAX_PWM}, not ({left}, {right})")
    return command(MOTOR_RAW_PWM, left, right)


def reset_encoders() -> bytes:
    """`r`: both counts back to 0 (and the PID reset)."""
    return command(RESET_ENCODERS)


def get_baud() -> bytes:
    """`b`: the board answers its baud rate (a cheap "are you there")."""
    return command(GET_BAUDRATE)


def update_pid(kp: int, kd: int, ki: int, ko: int) -> bytes:
    """`u Kp:Kd:Ki:Ko`: the PID gains (integers; output = (Kp e - Kd d + I) / Ko)."""
    return f"{UPDATE_PID} {int(kp)}:{int(kd)}:{int(ki)}:{int(ko)}\r".encode("ascii")


# ------------------------------------------------------------------ replies
def _text(line: str | bytes) -> str:
    if isinstance(line, bytes):
        line = line.decode("ascii", errors="replace")
    return line.strip()


def _int32(word: str) -> int:
    if not _INT.fullmatch(word):
        raise BadReply(f"not an integer: {word!r}")
    n = int(word)
    if not -(2**31) <= n < 2**31:
        raise BadReply(f"count out of the signed 32-bit range: {n}")
    return n


def parse_encoders(line: str | bytes) -> tuple[int, int]:
    """The reply to `e`: "left right" -> (left, right) [ticks]."""
    text = _text(line)
    if text == INVALID:
        raise BadReply("the board does not know `e` (firmware built without USE_BASE?)")
    words = text.split(" ")
    if len(words) != 2:
        raise BadReply(f"expected 'left right', got {text!r}")
    return _int32(words[0]), _int32(words[1])


def parse_ok(line: str | bytes) -> None:
    """The reply to `m`, `o`, `r`, `u`: "OK"."""
    text = _text(line)
    if text != OK:
        raise BadReply(f"expected 'OK', got {text!r}")


def parse_int(line: str | bytes) -> int:
    """A one-integer reply (`b`: the baud rate)."""
    text = _text(line)
    if text == INVALID:
        raise BadReply("the board answered 'Invalid Command'")
    return _int32(text)


def wrap32(n: int) -> int:
    """`n` wrapped to signed 32-bit, as the counters of the contract wrap."""
    return (n + 2**31) % 2**32 - 2**31


def ticks_per_frame(omega: float, ticks_per_rev: int, pid_rate: float, limit: int) -> int:
    """A wheel speed [rad/s] as the firmware's target [ticks per PID frame], rounded and clamped to +-limit."""
    ticks = round(omega * ticks_per_rev / (2.0 * math.pi) / pid_rate)
    return max(-limit, min(limit, ticks))


def wheel_speed(ticks: int, ticks_per_rev: int, pid_rate: float) -> float:
    """A target [ticks per PID frame] as a wheel speed [rad/s]."""
    return ticks * pid_rate * 2.0 * math.pi / ticks_per_rev


class Lines:
    """Bytes from the board to reply lines: CR/LF stripped, empty lines skipped, overlong lines cut."""

    def __init__(self) -> None:
        self._buf = b""
        self.dropped = 0  # [bytes] of lines longer than MAX_LINE, thrown away

    def feed(self, data: bytes) -> list[str]:
        """Add received bytes; return the complete non-empty lines."""
        *done, self._buf = (self._buf + data).split(b"\n")
        if len(self._buf) > MAX_LINE:
            self.dropped += len(self._buf)
            self._buf = b""
        out = []
        for raw in done:
            if len(raw) > MAX_LINE:
                self.dropped += len(raw)
                continue
            text = _text(raw)
            if text:
                out.append(text)
        return out

    def clear(self) -> None:
        """Throw a partial line away (counted in `dropped`)."""
        self.dropped += len(self._buf.strip())
        self._buf = b""
