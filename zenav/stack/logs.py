"""Bounded log files: a writer that rotates by size and cuts long lines, and a pipe reader feeding it.

A child process writes into a pipe; `pump` (on its own thread) reads it line by line
and hands each line to a `RotatingLog`, so the launcher, not the child, holds the
file and can rotate it. The pump reads as fast as lines come, so a child never blocks
on a full pipe, and a line is never held whole in memory: past `line_max` bytes the
rest is read and dropped, and the kept head ends with a note of how much was cut.
"""

from __future__ import annotations

import threading
from pathlib import Path
from typing import IO

LOG_BYTES = 5 * 2**20  # [bytes] a log file is rotated past this size
LOG_FILES = 5  # files kept per log: <name>.log, <name>.log.1 ... <name>.log.4 (the oldest)
LINE_MAX = 2000  # [bytes] a longer line is cut to this, with a note of the rest's size
READ_CHUNK = 65536  # [bytes] at most this much of one line is read at a time


def cut_note(cut: int) -> bytes:
    """The note that ends a cut line."""
    return f"... ({cut} more bytes cut)".encode()


class RotatingLog:
    """An append-only log file, rotated at `max_bytes` keeping `files` files; lines cut at `line_max`."""

    def __init__(self, path: Path, max_bytes: int = LOG_BYTES, files: int = LOG_FILES, line_max: int = LINE_MAX) -> None:
        self.path, self.max_bytes, self.files, self.line_max = path, max_bytes, max(files, 1), line_max
        self.last = ""  # the last non-empty line written (without its newline)
        self._lock = threading.Lock()  # one child's successive runs may write at once for a moment
        path.parent.mkdir(parents=True, exist_ok=True)
        self._file = open(path, "ab")

    def write(self, line: bytes, cut: int = 0) -> None:
        """Append one line (its newline added if missing); `cut` more bytes of it were already dropped."""
        line = line.rstrip(b"\r\n")
        if len(line) > self.line_max:
            line, cut = line[: self.line_max], cut + len(line) - self.line_max
        if cut:
            line += cut_note(cut)
        with self._lock:
            if self._file.closed:
                return
            if self._file.tell() + len(line) + 1 > self.max_bytes and self._file.tell() > 0:
                self._rotate()
            self._file.write(line + b"\n")
            self._file.flush()
            if line.strip():
                self.last = line.decode(errors="replace")

    def _rotate(self) -> None:
        """<name>.log -> <name>.log.1 -> ... ; the oldest beyond `files` is dropped."""
        self._file.close()
        paths = [self.path, *(self.path.with_name(f"{self.path.name}.{i}") for i in range(1, self.files))]
        paths[-1].unlink(missing_ok=True)
        for older, newer in zip(reversed(paths[1:]), reversed(paths[:-1]), strict=True):
            if newer.exists():
                newer.rename(older)
        self._file = open(self.path, "ab")

    def close(self) -> None:
        """Close the file; later writes are dropped."""
        with self._lock:
            self._file.close()


def pump(stream: IO[bytes], log: RotatingLog) -> None:
    """Copy `stream`'s lines into `log` until end of file, cutting long lines as they are read."""
    limit = log.line_max + 1
    with stream:
        while line := stream.readline(limit):
            cut = 0
            if not line.endswith(b"\n") and len(line) == limit:  # a long line: drop its rest, counting it
                while rest := stream.readline(READ_CHUNK):
                    cut += len(rest.rstrip(b"\r\n"))
                    if rest.endswith(b"\n"):
                        break
            log.write(line, cut)


def start_pump(stream: IO[bytes], log: RotatingLog, name: str) -> threading.Thread:
    """Run `pump` on a daemon thread."""
    thread = threading.Thread(target=pump, args=(stream, log), name=f"log-{name}", daemon=True)
    thread.start()
    return thread
