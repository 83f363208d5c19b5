"""Child processes of a stack: start, watch, restart with backoff, give up on crash loops, stop in order.

`Launcher` keeps named child processes. Each one's stdout and stderr go through a
pipe to a reader thread that writes its rotating log (`zenav.stack.logs`), and every
event line also goes to `<log_dir>/launcher.log`. With `restart=True` (`zenav up`)
`poll` restarts a child that exits, after a delay that doubles per quick crash; more
than `max_crashes` exits within `crash_window` and it gives up on that child. With
`hang_after`, a child whose heartbeat (`beat`: `zenav up` calls it on each diag)
stopped while others beat is SIGTERMed, SIGKILLed HANG_GRACE later, and restarted like a
crash (while no child is heard at all, nobody is hung: the launcher's own link or the
stack clock stalled). Without
`restart` (the bench) `check` raises on any exit. `stop` stops groups of children in
order: SIGTERM to a group, SIGKILL to what is still running STOP_GRACE later.
`ProcStack` is a router process and, per robot, every service as its own process, as
the bench measures them.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from zenav import services as registry
from zenav.stack.inprocess import free_port
from zenav.stack.logs import LOG_BYTES, LOG_FILES, RotatingLog, start_pump

BACKOFF_FIRST = 0.5  # [s] first restart delay; doubles per quick crash
BACKOFF_MAX = 10.0  # [s]
STABLE_AFTER = 30.0  # [s] a run this long resets the backoff
MAX_CRASHES = 5  # more exits than this within CRASH_WINDOW: give up on the child
CRASH_WINDOW = 60.0  # [s]
FIRST_BEAT = 60.0  # [s] a watched child with no heartbeat this long after its start is hung
HANG_GRACE = 2.0  # [s] between SIGTERM and SIGKILL of a hung child
STOP_GRACE = 5.0  # [s] between SIGTERM and SIGKILL
PUMP_JOIN = 0.5  # [s] an exited child's log reader gets this long to write its last lines
ROUTER_START = 20.0  # [s] a router process gets this long to listen
CLK_TCK = os.sysconf("SC_CLK_TCK")  # [ticks/s] unit of utime and stime in /proc/<pid>/stat


def exit_reason(code: int) -> str:
    """'exit code 1' or 'killed by SIGKILL'."""
    if code < 0:
        try:
            return f"killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"killed by signal {-code}"
    return f"exit code {code}"


@dataclass(frozen=True)
class ProcSample:
    """One process at one moment."""

    cpu: float  # [s] user + system CPU time since the process started
    rss: int  # [bytes] resident memory now
    waited: float  # [s] its threads spent ready to run, waiting for a core, since they started
    runs: int  # times its threads were given a core since they started (each wake-up, each preemption)


def read_proc(pid: int) -> ProcSample:
    """CPU time (utime + stime), resident memory and the scheduler's waits (`_waits`) of a live process."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()  # after the command name, which may hold spaces
    utime, stime = int(fields[11]), int(fields[12])  # fields 14 and 15 of proc(5)
    rss = 0
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                rss = int(line.split()[1]) * 1024
    return ProcSample((utime + stime) / CLK_TCK, rss, *_waits(pid))


def _waits(pid: int) -> tuple[float, int]:
    """[s] the process's threads waited for a core, and how many times they got one, summed over the
    threads it has now (/proc/<pid>/task/*/schedstat); (0, 0) where the kernel keeps no schedstat."""
    waited = runs = 0
    try:
        tids = os.listdir(f"/proc/{pid}/task")
    except OSError:
        return 0.0, 0
    for tid in tids:
        try:
            with open(f"/proc/{pid}/task/{tid}/schedstat") as f:
                _, wait, n = f.read().split()
        except (OSError, ValueError):  # a thread that ended meanwhile
            continue
        waited, runs = waited + int(wait), runs + int(n)
    return waited / 1e9, runs


def service_argv(name: str, args: Sequence[str]) -> list[str]:
    """The command line of one service process."""
    return [sys.executable, "-m", f"zenav.services.{name}", *args]


@dataclass
class Child:
    """One named child process, its log and its restart state (times on the launcher's clock [s])."""

    name: str
    argv: list[str]
    log: RotatingLog
    proc: subprocess.Popen[bytes] | None = None
    pump: threading.Thread | None = None
    started: float = 0.0
    restarts: int = 0
    hangs: int = 0  # times it was killed for a stopped heartbeat
    crashes: list[float] = field(default_factory=list)  # exit times within the crash window
    backoff: float = BACKOFF_FIRST  # [s]
    restart_at: float | None = None
    kill_at: float | None = None  # when a hung child gets SIGKILL
    hung: str = ""  # why it is being killed
    last_exit: str = ""
    gave_up: str = ""  # why it is no longer restarted ('' while it is)


@dataclass
class Heard:
    """When the launcher last heard any heartbeat, and since when it has without a gap [s]."""

    at: float
    since: float


@dataclass
class Launcher:
    """Named child processes; `events` receives one line per thing that happened."""

    log_dir: Path
    restart: bool = True  # restart children that exit (else `check` reports them)
    events: Callable[[str], None] = print
    now: Callable[[], float] = time.monotonic
    max_crashes: int = MAX_CRASHES
    crash_window: float = CRASH_WINDOW  # [s]
    hang_after: float | None = None  # [s] a heartbeat silence this long is a hang (None: not watched)
    log_bytes: int = LOG_BYTES
    log_files: int = LOG_FILES
    children: dict[str, Child] = field(default_factory=dict)
    beats: dict[str, float] = field(default_factory=dict)  # [s] the last heartbeat of each child
    heard: Heard | None = None
    stopping: bool = False
    journal: RotatingLog = field(init=False)

    def __post_init__(self) -> None:
        self.journal = RotatingLog(self.log_dir / "launcher.log", self.log_bytes, self.log_files)

    def say(self, line: str) -> None:
        """One event: to `events` and, stamped, to launcher.log."""
        self.journal.write(f"{time.strftime('%Y-%m-%d %H:%M:%S')} {line}".encode())
        self.events(line)

    def add(self, name: str, argv: list[str]) -> Child:
        """Declare a child (not started); its log is <log_dir>/<name>.log."""
        log = RotatingLog(self.log_dir / f"{name}.log", self.log_bytes, self.log_files)
        child = self.children[name] = Child(name, argv, log)
        return child

    def start(self, name: str) -> None:
        """Spawn one child in its own process group, its output piped to its log."""
        c = self.children[name]
        env = {**os.environ, "PYTHONUNBUFFERED": "1", "ZENAV_PARENT_PID": str(os.getpid())}
        # Own session and process group: a terminal's Ctrl-C reaches only the launcher, which
        # then stops the children in a safe order.
        c.proc = subprocess.Popen(c.argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=env, start_new_session=True)
        assert c.proc.stdout is not None
        c.pump = start_pump(c.proc.stdout, c.log, name)
        c.started, c.restart_at, c.kill_at, c.hung = self.now(), None, None, ""

    def start_all(self) -> None:
        """Spawn every child not running yet, in the order added."""
        for name, c in self.children.items():
            if c.proc is None:
                self.start(name)

    def beat(self, name: str) -> None:
        """A heartbeat of child `name`; safe from any thread."""
        now = self.now()
        self.beats[name] = now
        h = self.heard
        if h is None or self.hang_after is None or now - h.at > self.hang_after:
            self.heard = Heard(now, now)
        else:
            h.at = now

    def silence(self, c: Child, now: float) -> float | None:
        """How long `c` has been silent [s] while it should have beaten and others were heard (None: excused).

        The silence runs up to the last heartbeat of any child, not up to now: while the
        launcher hears no child at all (its own link to the router, or the stack clock that
        every service's diag timer follows, stalled), nobody's silence grows, so a child whose
        last diag came a little before the others' is not found hung while nobody is heard;
        after such a gap the silence counts from when the launcher heard one again."""
        own = self.beats.get(c.name)
        if own is not None and own >= c.started:
            since = own
        elif now - c.started < FIRST_BEAT:
            return None  # not up yet
        else:
            since = c.started
        h = self.heard
        if h is None or self.hang_after is None or now - h.at > self.hang_after:
            return None
        return max(min(h.at, now) - max(since, h.since), 0.0)

    def poll(self) -> list[str]:
        """Notice exits and hangs, restart what is due (with `restart`); call a few times a second.

        Returns the children given up on in this call."""
        if not self.restart or self.stopping:
            return []
        now = self.now()
        gave_up = []
        for c in self.children.values():
            if c.proc is None or c.gave_up:
                continue
            if c.restart_at is None:
                code = c.proc.poll()
                if code is None:
                    self._watch(c, now)
                elif self._exited(c, code, now):
                    gave_up.append(c.name)
            elif now >= c.restart_at:
                c.restarts += 1
                self.start(c.name)
                self.say(f"{c.name} restarted (pid {c.proc.pid if c.proc else '-'}, restart {c.restarts})")
        return gave_up

    def _watch(self, c: Child, now: float) -> None:
        """SIGTERM a running child whose heartbeat stopped; SIGKILL it HANG_GRACE later."""
        assert c.proc is not None
        if c.kill_at is not None:
            if now >= c.kill_at:
                c.proc.kill()
                c.kill_at = float("inf")
            return
        quiet = self.silence(c, now) if self.hang_after is not None else None
        if quiet is not None and self.hang_after is not None and quiet > self.hang_after:
            c.hangs += 1
            c.hung = f"no diag for {quiet:.1f} s"
            c.kill_at = now + HANG_GRACE
            self.say(f"{c.name} hung ({c.hung}; alive pid {c.proc.pid}): killing it (hang {c.hangs})")
            c.proc.send_signal(signal.SIGTERM)

    def _exited(self, c: Child, code: int, now: float) -> bool:
        """Schedule the restart of a child that exited; True if it crashed too often to restart."""
        if c.pump is not None:
            c.pump.join(PUMP_JOIN)  # its last lines, before quoting them
        ran = now - c.started
        if ran >= STABLE_AFTER:
            c.backoff = BACKOFF_FIRST
        c.last_exit = exit_reason(code) + (f" (hung: {c.hung})" if c.hung else "")
        c.crashes = [t for t in c.crashes if now - t < self.crash_window] + [now]
        why = f": {c.log.last[:200]}" if c.log.last else ""
        if len(c.crashes) > self.max_crashes:
            c.gave_up = f"{len(c.crashes)} exits in {self.crash_window:g} s, the last {c.last_exit}{why}"
            self.say(f"{c.name} gave up: {c.gave_up}")
            return True
        c.restart_at = now + c.backoff
        self.say(f"{c.name} {c.last_exit} after {ran:.1f} s{why}; restarting in {c.backoff:.1f} s")
        c.backoff = min(c.backoff * 2.0, BACKOFF_MAX)
        return False

    def check(self) -> None:
        """Raise RuntimeError naming any child that has exited, with its log's tail."""
        for c in self.children.values():
            if c.proc is not None and c.proc.poll() is not None:
                if c.pump is not None:
                    c.pump.join(PUMP_JOIN)
                tail = c.log.path.read_text(errors="replace")[-1500:]
                raise RuntimeError(f"{c.name} {exit_reason(c.proc.returncode)}:\n{tail}")

    def running(self) -> dict[str, int]:
        """The pid of every running child."""
        return {n: c.proc.pid for n, c in self.children.items() if c.proc is not None and c.proc.poll() is None}

    def sample(self) -> dict[str, ProcSample]:
        """CPU time and memory of every running child now."""
        return {n: read_proc(pid) for n, pid in self.running().items()}

    def stop(self, groups: Sequence[Sequence[str]], between: Callable[[Sequence[str]], None] = lambda group: None) -> None:
        """Stop the groups in order: SIGTERM a group's children, wait for them (SIGKILL after
        STOP_GRACE), call `between(group)`; children in no group are stopped last."""
        self.stopping = True
        named = {n for g in groups for n in g}
        rest = [n for n in self.children if n not in named]
        for group in [*groups, *([rest] if rest else [])]:
            running = [(n, p) for n in group if n in self.children and (p := self.children[n].proc) is not None and p.poll() is None]
            for _, proc in running:
                proc.send_signal(signal.SIGTERM)
            deadline = time.monotonic() + STOP_GRACE
            for name, proc in running:
                try:
                    proc.wait(max(deadline - time.monotonic(), 0.0))
                except subprocess.TimeoutExpired:
                    proc.kill()
                    proc.wait()
                    self.say(f"{name} did not stop in {STOP_GRACE:g} s: killed")
            between(group)

    def close(self) -> None:
        """Close every log, once the children are stopped (their last lines written first)."""
        for c in self.children.values():
            if c.pump is not None:
                c.pump.join(PUMP_JOIN)
            c.log.close()
        self.journal.close()


@dataclass
class ProcStack:
    """A router process and, per robot id, one process per service; no restarts."""

    robots: Sequence[str]
    services: Sequence[str]
    log_dir: Path
    args: Sequence[str] = ()  # common service arguments: --scenario, --seed, --set ...
    endpoint: str = field(default_factory=lambda: f"tcp/127.0.0.1:{free_port()}")
    compose: Sequence[str] = ()  # services of each robot run together in one process, "<robot>-composed" (stack/composed.py)
    realtime: int = 0  # the router's real-time priority (the services take theirs from `args`: --set deployment.realtime=N)
    launcher: Launcher = field(init=False)

    ROUTER = ("-", "router")  # the (robot, service) key of the router process

    def __post_init__(self) -> None:
        self.launcher = Launcher(self.log_dir, restart=False, events=lambda line: None)
        self.launcher.add(
            "router", [sys.executable, "-m", "zenav.stack.router", "--listen", self.endpoint, "--realtime", str(self.realtime)]
        )
        for robot in self.robots:
            common = ["--connect", self.endpoint, "--robot", robot, *self.args]
            for svc in self.separate:
                self.launcher.add(f"{robot}-{svc}", service_argv(svc, common))
            if self.compose:
                argv = [sys.executable, "-m", "zenav.stack.composed", "--services", ",".join(self.compose), *common]
                self.launcher.add(f"{robot}-composed", argv)

    @property
    def separate(self) -> list[str]:
        """The services that run as processes of their own."""
        return [s for s in self.services if s not in self.compose]

    @property
    def processes(self) -> list[str]:
        """Each robot's process names: its separate services, then "composed" if any are."""
        return [*self.separate, *(["composed"] if self.compose else [])]

    def start(self) -> ProcStack:
        """Start the router, wait until it listens, then every service of every robot (not waiting for them)."""
        self.launcher.start("router")
        self._wait_router()
        self.launcher.start_all()
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
        self.launcher.check()

    def _keys(self) -> dict[str, tuple[str, str]]:
        """Each process's name -> its (robot, service)."""
        return {f"{r}-{s}": (r, s) for r in self.robots for s in self.processes} | {"router": self.ROUTER}

    def sample(self) -> dict[tuple[str, str], ProcSample]:
        """CPU time and memory of every process now, by (robot, service)."""
        keys = self._keys()
        return {keys[n]: s for n, s in self.launcher.sample().items()}

    def pids(self) -> dict[tuple[str, str], int]:
        """The pid of every running process, by (robot, service)."""
        keys = self._keys()
        return {keys[n]: pid for n, pid in self.launcher.running().items()}

    def stop(self) -> None:
        """SIGTERM every service, in the registry's stop order without waiting between them (no
        robot of the bench drives anything real), wait for them all, then stop the router."""
        services = [f"{r}-{s}" for s in registry.stop_order(self.separate) for r in self.robots]
        self.launcher.stop([services + [f"{r}-composed" for r in self.robots if self.compose], ["router"]])
        self.launcher.close()

    def __enter__(self) -> ProcStack:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()
