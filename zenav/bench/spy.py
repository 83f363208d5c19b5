"""Where each robot service's process spends as deployed: py-spy's samples of its Python threads.

The profile section's cProfile run has every service in one process, on an in-memory bus.
Deployed, each service has a process of its own that takes its messages off the network on
Zenoh's threads, serves them there or on its worker, and sits idle between them. Here the
stack runs as in the latency section's first run (separate processes, clients of one
router, the navigator driving squares) and py-spy samples each of the robot's service
processes from outside for the window, without stopping it (`--nonblocking`). A sample is
a thread py-spy found active (running, or ready to run and waiting for a core: without
stopping the process it cannot tell the two apart) with Python on its stack. For each
process: its CPU over the window (/proc), the time its threads were active in Python, by
thread (Zenoh's readers `rx-*`, which serve a sample on the thread that brought it, and
the service's worker, `MainThread`), and its costliest functions by own samples.
`Condition.wait` there is the worker waking (taking its lock back). What no sample sees
is Zenoh's own work in Rust: reading and writing the sockets, routing, waking threads.

py-spy must be installed (`pip install py-spy`) and allowed to read other processes' memory
(ptrace: root, or `kernel.yama.ptrace_scope` 0); where it is not, the section says why.

`zenav bench profile` reports it with the profile.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

from zenav.bench import live
from zenav.bench.profile import RATE
from zenav.common.roles import ROBOT_SERVICES

SAMPLE_RATE = 500  # [Hz] py-spy's samples of each process
ATTACH = 30.0  # [s] allowed beyond the window for py-spy to attach and write its samples


@dataclass(frozen=True)
class Spied:
    """One process's samples over a window: one per thread active in Python at each sampling instant."""

    threads: Counter[str]  # thread name -> samples
    own: Counter[str]  # function -> samples it was the innermost frame of
    total: Counter[str]  # function -> samples it was on the stack in (once a sample, however deep)

    @property
    def samples(self) -> int:
        return sum(self.threads.values())


def parse(raw: str, comm: dict[int, str] | None = None) -> Spied:
    """py-spy's `--format raw --threads` output: a line per distinct stack, `thread (TID): NAME;frame;... COUNT`.

    A thread Python has no name of its own for (one of Zenoh's, which run callbacks: none, or "Dummy-N")
    takes its name in the OS from `comm` (tid -> name: /proc/<pid>/task/<tid>/comm), else keeps its id."""
    threads: Counter[str] = Counter()
    own: Counter[str] = Counter()
    total: Counter[str] = Counter()
    for line in raw.splitlines():
        stack, _, count = line.rpartition(" ")
        if not stack or not count.isdigit():
            continue
        thread, *frames = stack.split(";")
        n = int(count)
        threads[_thread_name(thread, comm or {})] += n
        if frames:
            own[frames[-1]] += n
            for f in set(frames):
                total[f] += n
    return Spied(threads, own, total)


def _thread_name(frame: str, comm: dict[int, str]) -> str:
    """ "thread (4642): worker" -> "worker"; an unnamed thread (or "Dummy-N") -> its OS name, else "thread (4642)"."""
    head, _, name = frame.partition(": ")
    name = name.strip()
    tid = head.removeprefix("thread (").removesuffix(")")
    if not name or name.startswith("Dummy-"):
        return comm.get(int(tid), head) if tid.isdigit() else head
    return name


def thread_names(pid: int) -> dict[int, str]:
    """tid -> the OS name of each thread of a running process (Zenoh's: rx-0, tx-0, app-0, ...)."""
    names = {}
    try:
        tids = os.listdir(f"/proc/{pid}/task")
    except OSError:
        return {}
    for tid in tids:
        try:
            names[int(tid)] = Path(f"/proc/{pid}/task/{tid}/comm").read_text().strip()
        except OSError:
            continue  # the thread ended
    return names


def executable() -> str | None:
    """The py-spy program: beside this interpreter (a venv's), else on PATH."""
    return shutil.which("py-spy", path=os.pathsep.join([str(Path(sys.executable).parent), os.environ.get("PATH", "")]))


def refused() -> str | None:
    """Why py-spy cannot sample this host's processes, or None if it can: tried on a process of this one's."""
    exe = executable()
    if exe is None:
        return "py-spy is not installed (pip install py-spy)"
    waits = "import time; print('up', flush=True); time.sleep(60)"
    target = subprocess.Popen([sys.executable, "-c", waits], stdout=subprocess.PIPE, text=True)
    try:
        assert target.stdout is not None
        target.stdout.readline()  # its interpreter is up: a dump before would find no Python in it
        done = subprocess.run([exe, "dump", "--nonblocking", "--pid", str(target.pid)], capture_output=True, text=True, timeout=30.0)
    finally:
        target.kill()
        target.wait()
        if target.stdout is not None:
            target.stdout.close()
    if done.returncode == 0:
        return None
    last = (done.stderr.strip().splitlines() or ["refused"])[-1]
    return f"py-spy may not read other processes here ({last}): run as root, or set kernel.yama.ptrace_scope to 0"


def record(pids: dict[str, int], seconds: int, rate: int = SAMPLE_RATE) -> dict[str, Spied]:
    """Sample every process of `pids` (name -> pid) at once for `seconds` (whole: py-spy's), without stopping them."""
    exe = executable()
    if exe is None:
        raise RuntimeError("py-spy is not installed")
    with tempfile.TemporaryDirectory(prefix="zenav-spy-") as tmp:
        outs = {name: Path(tmp) / f"{name}.txt" for name in pids}
        procs = {
            name: subprocess.Popen(
                [exe, "record", "--pid", str(pid), "--duration", str(seconds), "--rate", str(rate)]
                + ["--format", "raw", "--threads", "--function", "--nonblocking", "--output", str(outs[name])],
                stdout=subprocess.DEVNULL,
                stderr=subprocess.PIPE,
                text=True,
            )
            for name, pid in pids.items()
        }
        try:
            errors = {name: p.communicate(timeout=seconds + ATTACH)[1] for name, p in procs.items()}
        finally:
            for p in procs.values():
                if p.poll() is None:
                    p.kill()
                    p.wait()
        failed = [f"{name}: {errors[name].strip()[-300:]}" for name, p in procs.items() if p.returncode != 0]
        if failed:
            raise RuntimeError("py-spy failed: " + "; ".join(failed))
        return {name: parse(out.read_text(), thread_names(pids[name])) for name, out in outs.items()}


@dataclass(frozen=True)
class Deployed:
    """The robot's service processes sampled over one window of the live stack."""

    sampled: int  # [s] py-spy sampled each process (whole seconds: its --duration)
    rate: int  # [Hz] py-spy's samples
    cores: dict[str, float]  # service -> [cores] its process's CPU over the window (/proc; py-spy's start included)
    spied: dict[str, Spied]  # service -> its samples

    def active(self, samples: int) -> float:
        """[cores] the time active (on a core or ready for one) that `samples` of one process stand for."""
        return samples / self.rate / self.sampled

    def per_period(self, samples: int) -> float:
        """[us per sensor period] the time active that `samples` stand for."""
        return self.active(samples) / RATE * 1e6


def deployed(seconds: int, log_dir: Path, rate: int = SAMPLE_RATE) -> Deployed:
    """One robot's stack as separate processes at 100 Hz, its four robot services sampled for `seconds`."""
    spied: dict[str, Spied] = {}

    def during(pids: dict[tuple[str, str], int]) -> None:
        spied.update(record({s: pids[("r1", s)] for s in ROBOT_SERVICES}, seconds, rate))

    run = live.run(1, RATE, 1.0, seconds, log_dir, during=during)
    return Deployed(seconds, rate, {s: run.cpu[("r1", s)] / run.wall for s in ROBOT_SERVICES}, spied)


def lines(d: Deployed, top: int = 10) -> list[str]:
    """Each process's CPU, its threads' time active in Python, and its costliest functions, as text lines."""
    out = [f"{'service':<10} {'cpu':>7} {'python':>7}  active in Python, by thread [cores]"]
    for name, s in d.spied.items():
        threads = ", ".join(f"{t} {d.active(n):.4f}" for t, n in s.threads.most_common())
        out.append(f"{name:<10} {d.cores[name]:>7.4f} {d.active(s.samples):>7.4f}  {threads}")
    for name, s in d.spied.items():
        out += ["", f"{name} as deployed: top functions by own samples, then with callees, us active per sensor period (py-spy)"]
        out += [f"  {d.per_period(n):8.2f} {d.per_period(s.total[f]):8.2f}  {f}" for f, n in s.own.most_common(top)]
    return out
