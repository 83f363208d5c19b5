"""The safety bench's rig: the stack as processes, recorders of what it publishes, and the child processes.

The child processes (bench/child.py runs them): `operator` holds a Robot and sends one goal (to be
frozen); `flood` sends follow_path goals without waiting, and with `arrived` then says when they have
all reached the navigator; `big` sends an oversize payload.
"""

from __future__ import annotations

import json
import queue
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import zenoh

from zenav import services as registry
from zenav.bench import child
from zenav.common import codec
from zenav.common.bus import ZenohBus, zenoh_config
from zenav.common.client import Client, Latest
from zenav.robot import Robot
from zenav.stack.launcher import ProcStack

FIELD_X_MAX = 1.5  # [m] the bench field's edge ahead of the start pose (a straight drive leaves it soon)
OPERATOR_GOAL = (1.2, 0.0)  # [m] where the operator sends the robot
WAIT = 10.0  # [s] for any one thing to happen
# [bytes] a selector parameter over [limits] max_params (64 KiB): refused on arrival, in the navigator's bus callback
OVER_PARAMS = 70_000


class Arrivals:
    """Every message of one topic with its arrival time [s, monotonic]."""

    def __init__(self, client: Client, suffix: str) -> None:
        self.cond = threading.Condition()
        self.items: list[tuple[float, Any]] = []
        client.subscribe(suffix, self._on)

    def _on(self, msg: Any) -> None:
        with self.cond:
            self.items.append((time.monotonic(), msg))
            self.cond.notify_all()

    def first(self, pred: Callable[[float, Any], bool], timeout: float = WAIT) -> float:
        """Arrival time of the first message for which pred(time, msg) holds; TimeoutError."""
        found: list[float] = []

        def seen() -> bool:
            found[:] = [t for t, msg in self.items if pred(t, msg)][:1]
            return bool(found)

        with self.cond:
            if not self.cond.wait_for(seen, timeout):
                raise TimeoutError(f"no such message in {timeout} s")
        return found[0]

    def max_gap(self, start: float, end: float) -> float:
        """[s] the longest interval between arrivals within [start, end]."""
        with self.cond:
            times = [t for t, _ in self.items if start <= t <= end]
        return max((b - a for a, b in zip(times, times[1:], strict=False)), default=end - start)


class StackRig:
    """A router and the whole stack as processes, and a client that records what they publish."""

    def __init__(self, log_dir: Path) -> None:
        # The field's edge is no wall here (sim.walls): what is tested is the navigator stopping a robot whose
        # pose leaves the field, as a real one pushed out or lost would.
        edge = ("--set", f"field.x_max={FIELD_X_MAX}", "--set", "sim.walls=false")
        self.stack = ProcStack(("r1",), registry.NAMES, log_dir, edge).start()
        self.endpoint = self.stack.endpoint
        self.client = Client("r1", self.endpoint)
        self.client.wait_alive(registry.NAMES, timeout=90)
        self.session = self.bus.session
        self.cmd = Arrivals(self.client, "cmd_vel")
        self.wheels = Arrivals(self.client, "motors/wheels")
        self.pose = Arrivals(self.client, "pose")
        self.truth = self.client.latest("sim/truth")
        self.nav = self.client.latest("nav/state")
        self.clock = self.client.latest("clock")

    @property
    def bus(self) -> ZenohBus:
        bus = self.client.bus
        assert isinstance(bus, ZenohBus)
        return bus

    def one(self, suffix: str) -> Any:
        """The next message on a topic (subscribed only until it comes)."""
        got = Latest()
        handle = self.client.subscribe(suffix, got.put)
        try:
            return got.wait(timeout=WAIT)
        finally:
            handle.undeclare()

    def counter(self, service: str, name: str) -> int:
        """A diag counter of a service, from its newest diag."""
        return int(self.client.latest(f"diag/{service}").wait(timeout=WAIT).counters.get(name, 0))

    def wait_counter(self, service: str, name: str, above: int) -> int:
        """Block until the service's diag shows counter `name` above `above`; its value."""
        d = self.client.latest(f"diag/{service}").wait(lambda d: d.counters.get(name, 0) > above, timeout=WAIT)
        return int(d.counters[name])

    def ready(self) -> None:
        """Block until the navigator would take a goal."""
        with Robot("r1", bus=self.client.bus, lease=False) as bot:
            bot.wait_ready(60)

    def close(self) -> None:
        self.client.close()
        self.stack.stop()


def read_lines(proc: subprocess.Popen[str]) -> queue.Queue[str]:
    """The child's stdout lines, read by a thread (and closed at its end), to wait on with a timeout."""
    lines: queue.Queue[str] = queue.Queue()

    def read() -> None:
        assert proc.stdout is not None
        with proc.stdout:
            for line in proc.stdout:
                lines.put(line)

    threading.Thread(target=read, daemon=True).start()
    return lines


def end_child(proc: subprocess.Popen[str]) -> None:
    """Kill a child (frozen or not) and close its stdin."""
    proc.kill()
    proc.wait()
    if proc.stdin is not None:
        proc.stdin.close()


def start_child(fn: Callable[..., None], *args: object) -> tuple[subprocess.Popen[str], queue.Queue[str]]:
    """`fn(*args)`, one of the child processes below, in a process of its own; and its stdout lines."""
    proc = subprocess.Popen(child.argv(fn, *args), stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    return proc, read_lines(proc)


# ------------------------------------------------------------------ child processes
def operator(endpoint: str) -> None:
    """Hold a Robot, send one goal, then wait (to be frozen)."""
    with Robot("r1", endpoint) as bot:
        bot.wait_ready(60)
        bot.move_to_point(*OPERATOR_GOAL)
        sys.stdin.read()  # until killed


def flood(endpoint: str, goals: int, points: int, arrived: bool = False) -> None:
    """Send `goals` follow_path goals of `points` points without waiting; print when sent, then every reply's
    time and whether it was ok (a goal started), as JSON.

    `arrived`: after the goals, a query with a selector parameter over max_params goes on the same session: the
    navigator refuses it in its bus callback, on arrival, and a link delivers in order, so its answer says every
    goal has reached the navigator (queued there, or served); then print "arrived"."""
    session = zenoh.open(zenoh_config("client", endpoint))
    path = [[0.2 + 0.3 * (i % 2), 0.5 * i / points] for i in range(points)]
    payload = codec.encode({"points": path})
    replies: list[tuple[float, bool]] = []
    done = threading.Event()

    def on_reply(reply: zenoh.Reply) -> None:
        replies.append((time.monotonic(), reply.ok is not None))
        if len(replies) == goals:
            done.set()

    for _ in range(goals):
        session.get("zenav/r1/nav/follow_path", on_reply, payload=payload, timeout=30)
    print(f"sent {time.monotonic()}", flush=True)
    if arrived:
        list(session.get(f"zenav/r1/nav/follow_path?points={'1' * OVER_PARAMS}", timeout=30))
        print(f"arrived {time.monotonic()}", flush=True)
    done.wait(30)
    print(json.dumps(replies), flush=True)
    session.close()


def big(endpoint: str, key: str, size: int, query: bool) -> None:
    """Send `size` zero bytes on `key` (as a query's payload if `query`), then a malformed message the same way;
    print when it starts and when both went out (monotonic)."""
    session = zenoh.open(zenoh_config("client", endpoint))
    print(f"start {time.monotonic()}", flush=True)
    for data in (bytes(size), b"\x93 not a message"):
        if query:
            session.get(key, lambda reply: None, payload=data, timeout=WAIT)  # the big one gets no reply: not waited for
        else:
            session.put(key, data, congestion_control=zenoh.CongestionControl.BLOCK)
    print(f"sent {time.monotonic()}", flush=True)
    sys.stdin.read()  # until killed: the session stays open while the parent watches
