"""Keyboard driving, pure: bytes read from a terminal -> keys -> the body velocity to command, with a dead-man timeout."""

from __future__ import annotations

from dataclasses import dataclass, replace

KEYS = {  # bytes a terminal sends -> key name
    b"\x1b[A": "up",
    b"\x1bOA": "up",
    b"\x1b[B": "down",
    b"\x1bOB": "down",
    b"\x1b[C": "right",
    b"\x1bOC": "right",
    b"\x1b[D": "left",
    b"\x1bOD": "left",
    **{bytes([c]): name for chars, name in (("wW", "up"), ("sS", "down"), ("aA", "left"), ("dD", "right")) for c in chars.encode()},
    b" ": "stop",
    b"q": "quit",
    b"Q": "quit",
    b"\x04": "quit",  # Ctrl-D
}
DIRECTIONS = {"up": (1.0, 0.0), "down": (-1.0, 0.0), "left": (0.0, 1.0), "right": (0.0, -1.0)}  # (forward, turn) signs


def split_keys(data: bytes) -> list[str]:
    """The keys in a chunk read from a terminal (other keys and escape sequences are skipped)."""
    out, i = [], 0
    while i < len(data):
        for size in (3, 1):
            name = KEYS.get(data[i : i + size])
            if name is not None:
                out.append(name)
                i += size
                break
        else:
            i += _sequence_length(data, i)
    return out


def _sequence_length(data: bytes, i: int) -> int:
    """Bytes of the unknown key at `i`: an escape sequence up to its final byte, else one byte."""
    if data[i : i + 2] not in (b"\x1b[", b"\x1bO"):
        return 1
    j = i + 2
    while j < len(data) and not 0x40 <= data[j] <= 0x7E:  # parameters, up to the final byte
        j += 1
    return min(j + 1, len(data)) - i


@dataclass(frozen=True)
class Drive:
    """What the keys asked for: the body velocity, and when a driving key came last."""

    speed: float  # [m/s] forward speed of up/down
    turn: float  # [rad/s] turn rate of left/right
    deadman: float  # [s] with no key for this long, the command is zero
    v: float = 0.0  # [m/s]
    omega: float = 0.0  # [rad/s]
    last: float | None = None  # [s] when the last driving key came; None: stopped


def press(drive: Drive, key: str, now: float) -> Drive:
    """The state after `key` at `now` [s]: a direction drives that way, `stop` stops; others change nothing."""
    if key == "stop":
        return replace(drive, v=0.0, omega=0.0, last=None)
    if key in DIRECTIONS:
        fwd, turn = DIRECTIONS[key]
        return replace(drive, v=fwd * drive.speed, omega=turn * drive.turn, last=now)
    return drive


def command(drive: Drive, now: float) -> tuple[float, float]:
    """The (v [m/s], omega [rad/s]) to send at `now` [s]: zero once no key came for `deadman` seconds."""
    if drive.last is None or now - drive.last > drive.deadman:
        return 0.0, 0.0
    return drive.v, drive.omega
