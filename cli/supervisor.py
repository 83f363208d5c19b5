"""Child processes of `zenav up`: start, watch, restart with backoff, stop in order."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Optional, Sequence

BACKOFF_FIRST = 0.5  # [s] first restart delay; doubles per quick crash
BACKOFF_MAX = 10.0  # [s]
STABLE_AFTER = 30.0  # [s] a run this long resets the backoff
STOP_GRACE = 3.0  # [s] between SIGTERM and SIGKILL


def exit_reason(code: int) -> str:
    """'exit code 1' or 'killed by SIGKILL'."""
    if code < 0:
        try:
            return f"killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"killed by signal {-code}"
    return f"exit code {code}"


def last_line(path: Path) -> str:
    """The last non-empty line of a log file ('' if none)."""
    try:
        with open(path, "rb") as f:
            f.seek(max(0, f.seek(0, os.SEEK_END) - 4096))
            lines = [ln for ln in f.read().decode(errors="replace").splitlines() if ln.strip()]
    except OSError:
        return ""
    return lines[-1][:200] if lines else ""


@dataclass
class Child:
    name: str
    argv: list[str]
    log: Path
    proc: Optional[subprocess.Popen] = None
    started: float = 0.0
    restarts: int = 0
    backoff: float = BACKOFF_FIRST
    restart_at: Optional[float] = None
    last_exit: str = ""


@dataclass
class Supervisor:
    """Keeps each named child running; `events` receives one line per thing that happened."""

    children: dict[str, Child]
    events: Callable[[str], None] = print
    now: Callable[[], float] = time.monotonic
    stopping: bool = False
    env: dict[str, str] = field(default_factory=dict)

    @classmethod
    def for_services(cls, names: Sequence[str], args: list[str], log_dir: Path, **kw) -> Supervisor:
        log_dir.mkdir(parents=True, exist_ok=True)
        children = {
            n: Child(n, [sys.executable, "-m", f"zenav.services.{n}", *args], log_dir / f"{n}.log") for n in names
        }
        return cls(children, **kw)

    def start(self, name: str) -> None:
        c = self.children[name]
        env = {**os.environ, "PYTHONUNBUFFERED": "1", "ZENAV_PARENT_PID": str(os.getpid()), **self.env}
        with open(c.log, "ab") as log:
            # Own process group: a terminal's Ctrl-C reaches only `zenav up`, which then
            # stops the children in a safe order.
            c.proc = subprocess.Popen(c.argv, stdout=log, stderr=subprocess.STDOUT, env=env, process_group=0)
        c.started, c.restart_at = self.now(), None

    def start_all(self) -> None:
        for name in self.children:
            self.start(name)

    def poll(self) -> None:
        """Notice exits and restart what is due; call a few times a second."""
        now = self.now()
        for c in self.children.values():
            if c.proc is not None and c.restart_at is None:
                code = c.proc.poll()
                if code is None or self.stopping:
                    continue
                ran = now - c.started
                if ran >= STABLE_AFTER:
                    c.backoff = BACKOFF_FIRST
                c.last_exit = exit_reason(code)
                why = last_line(c.log)
                c.restart_at = now + c.backoff
                self.events(f"{c.name} {c.last_exit} after {ran:.1f} s{': ' + why if why else ''}; restarting in {c.backoff:.1f} s")
                c.backoff = min(c.backoff * 2.0, BACKOFF_MAX)
            elif c.restart_at is not None and now >= c.restart_at and not self.stopping:
                c.restarts += 1
                self.start(c.name)
                self.events(f"{c.name} restarted (pid {c.proc.pid}, restart {c.restarts})")

    def stop(self, order: Sequence[str], between: Callable[[str], None] = lambda name: None) -> None:
        """SIGTERM each child in `order`, waiting for it (SIGKILL after a grace period)."""
        self.stopping = True
        for name in order:
            c = self.children.get(name)
            if c is None or c.proc is None or c.proc.poll() is not None:
                continue
            c.proc.send_signal(signal.SIGTERM)
            try:
                c.proc.wait(STOP_GRACE)
            except subprocess.TimeoutExpired:
                c.proc.kill()
                c.proc.wait()
                self.events(f"{name} did not stop in {STOP_GRACE} s: killed")
            between(name)
