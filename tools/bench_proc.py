"""A router and the services of one or more robots as separate processes, as `zenav up`
starts them, with each process's CPU time and resident memory read from /proc."""
from __future__ import annotations

import argparse
import os
import signal
import socket
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

from zenav.cli import router
from zenav.cli.up import STOP_ORDER
from zenav.common.stack import free_port

CLK_TCK = os.sysconf("SC_CLK_TCK")  # [ticks/s] unit of utime and stime in /proc/<pid>/stat
STOP_GRACE = 5.0  # [s] between SIGTERM and SIGKILL
ROUTER_START = 20.0  # [s] the router process gets this long to listen


@dataclass(frozen=True)
class ProcSample:
    """One process at one moment."""

    cpu: float  # [s] user + system CPU time since the process started
    rss: int  # [bytes] resident memory now


def read_proc(pid: int) -> ProcSample:
    """CPU time (utime + stime) and resident memory of a live process."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()  # after the command name, which may hold spaces
    utime, stime = int(fields[11]), int(fields[12])  # fields 14 and 15 of proc(5)
    rss = 0
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                rss = int(line.split()[1]) * 1024
    return ProcSample((utime + stime) / CLK_TCK, rss)


@dataclass
class ProcStack:
    """A router process and, per robot id, one process per service."""

    robots: Sequence[str]
    services: Sequence[str]
    log_dir: Path
    args: Sequence[str] = ()  # common service arguments: --scenario, --seed, --set ...
    endpoint: str = field(default_factory=lambda: f"tcp/127.0.0.1:{free_port()}")
    procs: dict[tuple[str, str], subprocess.Popen] = field(default_factory=dict)  # (robot, service) -> process

    ROUTER = ("-", "router")  # the key of the router process

    def _spawn(self, key: tuple[str, str], argv: list[str]) -> None:
        env = {**os.environ, "PYTHONUNBUFFERED": "1", "ZENAV_PARENT_PID": str(os.getpid())}
        with open(self.log_dir / f"{key[0]}-{key[1]}.log", "ab") as log:
            # Own process group: a Ctrl-C at the terminal reaches the bench, which stops these.
            self.procs[key] = subprocess.Popen(argv, stdout=log, stderr=subprocess.STDOUT, env=env, process_group=0)

    def start(self) -> ProcStack:
        """Start the router, then every service of every robot (not waiting for them)."""
        self.log_dir.mkdir(parents=True, exist_ok=True)
        self._spawn(self.ROUTER, [sys.executable, "-m", "zenav.tools.bench_proc", "--listen", self.endpoint])
        self._wait_router()
        for robot in self.robots:
            for svc in self.services:
                argv = [sys.executable, "-m", f"zenav.services.{svc}", "--connect", self.endpoint, "--robot", robot]
                self._spawn((robot, svc), argv + list(self.args))
        return self

    def _wait_router(self) -> None:
        host, port = self.endpoint.removeprefix("tcp/").rsplit(":", 1)
        deadline = time.monotonic() + ROUTER_START
        while time.monotonic() < deadline:
            self.check()
            try:
                socket.create_connection((host, int(port)), timeout=1.0).close()
                return
            except OSError:
                time.sleep(0.05)  # polling a port that is not open yet
        raise RuntimeError(f"router not listening on {self.endpoint} after {ROUTER_START} s")

    def check(self) -> None:
        """Raise RuntimeError naming any process that has exited, with its log's tail."""
        for (robot, svc), p in self.procs.items():
            if p.poll() is not None:
                log = (self.log_dir / f"{robot}-{svc}.log").read_text(errors="replace")[-1500:]
                raise RuntimeError(f"{svc} of {robot} exited with {p.returncode}:\n{log}")

    def sample(self) -> dict[tuple[str, str], ProcSample]:
        """CPU time and memory of every process now."""
        return {key: read_proc(p.pid) for key, p in self.procs.items()}

    def stop(self) -> None:
        """SIGTERM the services in the order `zenav up` uses, then the router; SIGKILL what lingers."""
        services = [(r, s) for s in STOP_ORDER for r in self.robots if (r, s) in self.procs]
        for group in (services, [self.ROUTER]):
            for key in group:
                if self.procs[key].poll() is None:
                    self.procs[key].send_signal(signal.SIGTERM)
            for key in group:
                try:
                    self.procs[key].wait(STOP_GRACE)
                except subprocess.TimeoutExpired:
                    self.procs[key].kill()
                    self.procs[key].wait()

    def __enter__(self) -> ProcStack:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()


def main(argv: list[str] | None = None) -> int:
    """The router process: what `zenav router --listen EP` runs."""
    parser = argparse.ArgumentParser(prog="bench_proc", description="a Zenoh router for the bench")
    parser.add_argument("--listen", required=True, help="endpoint")
    return router.run(argparse.Namespace(listen=parser.parse_args(argv).listen, zenoh_config=None))


if __name__ == "__main__":
    raise SystemExit(main())
