"""Sensor-to-wheel latency through the stack, stage by stage, on the host's wall clock.

The chain is the configured one (roles.chain): with the navigator's control loop on odom,
sim -> odometry -> navigator -> motor; on pose, the localizer between the odometry and the
navigator. Every message of the chain carries the t of the encoder sample it descends from, and
the sim stamps the `sim/truth` message of that t with its wall clock, taken once the
sample's sensors are read, just before it publishes them. An observer subscribed to
the chain stamps each arrival. For each t, end to end = arrival of `motors/wheels` -
the sim's stamp (now - t on motors/wheels at a realtime factor of 1), and it splits
exactly into: delivery (sim to a subscriber: one hop, the observer's own), then per
service the hop into it plus its work (its output's arrival - its input's arrival).

A late VPS fix makes the localizer re-integrate its history since the fix's capture:
the observer also stamps `vps/pose`, and splits the localizer's stage and end to end of
the odom samples that arrive just after a fix from the others (AROUND_FIX), to show
whether that work holds up the chain.

The observer is a process of its own that does nothing else (`Observer`, `observe`
run by bench/child.py), in the services' Zenoh mode: a
stamp is not held up by the bench's own threads. The bare chain (bench/chain.py) is
measured by the same observer.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import cast

import numpy as np

from zenav.bench import child
from zenav.common import codec, keys, roles
from zenav.common import messages as m
from zenav.common.app import PEER_LISTEN
from zenav.common.bus import Bus, ZenohBus
from zenav.common.config import Settings
from zenav.common.roles import ROBOT_SERVICES
from zenav.services.navigator.params import Params

READY = "ready"  # the observer's first line on stdout


class _Stamped(m.Topic, frozen=True, kw_only=True):
    """Any chain message, read for its t alone."""

    t: float


OUTPUT = {"odometry": "odom", "localizer": "pose", "navigator": "cmd_vel", "motor": "motors/wheels"}  # each robot service's
INPUT = {"odometry": "sensors/encoders", "localizer": "odom", "motor": "cmd_vel"}  # the navigator's: its control_on, a topic
STAGES = ("delivery", *ROBOT_SERVICES)  # every stage a chain may have, in order: what ends with each chain message


def input_of(service: str, control_on: str) -> str:
    """The chain message a robot service reads (the localizer's off the chain too)."""
    return control_on if service == "navigator" else INPUT[service]


def chain(control_on: str) -> tuple[str, ...]:
    """The chain's messages: the encoder sample, then each of its services' output, in order."""
    return ("sensors/encoders", *(OUTPUT[s] for s in roles.chain(control_on)))


def stages(control_on: str) -> tuple[str, ...]:
    """The chain's stages, in order: what ends with each of its messages."""
    return ("delivery", *roles.chain(control_on))


def present(measured: dict[str, list[float]]) -> tuple[str, ...]:
    """The stages a measured chain has (its services' stages, in order)."""
    return tuple(s for s in STAGES if s in measured)


def configured() -> str:
    """What the navigator's control loop runs on in the stack `zenav up` starts here ($ZENAV_CONFIG, or the default)."""
    return Settings.load(os.environ.get("ZENAV_CONFIG")).section("navigator", Params).control_on


END_TO_END = "end to end"
FIX = "vps/pose"
# An odom sample that arrives this soon after a fix would meet the fix's replay were the fix served as it came
# (a replay took 0.6 to 2.5 ms on the hosts measured).
NEAR_FIX = 0.003  # [s]
AROUND_FIX = (f"odom within {NEAR_FIX * 1e3:g} ms after a fix", "other odom")
SPLIT = ("localizer", END_TO_END)  # what is split by AROUND_FIX: stages() gives e.g. "localizer, other odom"


@dataclass(frozen=True)
class Stats:
    """A latency distribution [ms]."""

    n: int
    p50: float
    p90: float
    p99: float
    max: float

    @classmethod
    def of(cls, values_ms: Sequence[float]) -> Stats:
        if len(values_ms) == 0:
            return cls(0, *([float("nan")] * 4))
        p50, p90, p99 = np.percentile(values_ms, [50, 90, 99])
        return cls(len(values_ms), float(p50), float(p90), float(p99), float(np.max(values_ms)))


class ChainRecorder:
    """Stamps the wall arrival of each chain message of one robot, by t (in the observer process)."""

    def __init__(self, bus: Bus, robot: str, control_on: str) -> None:
        self._lock = threading.Lock()
        self.chain, self.names = chain(control_on), stages(control_on)  # its messages, its stages
        self.stamp: dict[float, float] = {}  # t -> sim's wall clock at t [s]
        self.arrival: dict[str, dict[float, float]] = {topic: {} for topic in self.chain}  # topic -> t -> wall [s]
        self.fixes: list[float] = []  # wall arrival of each fix [s]
        bus.subscribe(keys.key(robot, "sim/truth"), self._on_truth)
        bus.subscribe(keys.key(robot, FIX), self._on_fix)
        for topic in self.chain:
            bus.subscribe(keys.key(robot, topic), self._stamper(topic))

    def _on_truth(self, key: str, data: bytes) -> None:
        try:
            msg = codec.decode(data, m.Truth)
        except codec.BadInput:
            return
        with self._lock:
            self.stamp[msg.t] = msg.wall

    def _on_fix(self, key: str, data: bytes) -> None:
        now = time.time()
        try:
            codec.decode(data, m.VpsPose)
        except codec.BadInput:
            return
        with self._lock:
            self.fixes.append(now)

    def _stamper(self, topic: str) -> Callable[[str, bytes], None]:
        table = self.arrival[topic]

        def on_msg(key: str, data: bytes) -> None:
            now = time.time()  # before anything else: the arrival as this process sees it
            try:
                t = codec.decode(data, _Stamped).t
            except codec.BadInput:
                return
            with self._lock:
                table.setdefault(t, now)  # the first: a watchdog stop repeats a t

        return on_msg

    def stages(self) -> dict[str, list[float]]:
        """Per stage and end to end, the latencies [ms] of every t that went all the way through."""
        topics = self.chain
        with self._lock:
            ts = [t for t in self.arrival[topics[-1]] if t in self.stamp and all(t in self.arrival[c] for c in topics)]
            times = np.array([[self.stamp[t]] + [self.arrival[c][t] for c in topics] for t in ts]).reshape(-1, len(topics) + 1)
            fixes = np.array(self.fixes)
        steps = np.diff(times, axis=1) * 1e3  # [ms] column k: chain[k] arrival - the one before
        out = {stage: steps[:, k] for k, stage in enumerate(self.names)}
        out[END_TO_END] = (times[:, -1] - times[:, 0]) * 1e3
        near = near_fix(times[:, 1 + topics.index("odom")], fixes)
        for name in (n for n in SPLIT if n in out):
            for group, mask in zip(AROUND_FIX, (near, ~near)):
                out[f"{name}, {group}"] = out[name][mask]
        return {name: values.tolist() for name, values in out.items()}


def near_fix(arrivals: np.ndarray, fixes: np.ndarray) -> np.ndarray:
    """Per arrival [s]: whether a fix arrived in the NEAR_FIX before it."""
    if len(fixes) == 0:
        return np.zeros(len(arrivals), dtype=bool)
    fixes = np.sort(fixes)
    last = np.searchsorted(fixes, arrivals, side="right") - 1  # the newest fix at or before each arrival
    return cast(np.ndarray, (last >= 0) & (arrivals - fixes[np.maximum(last, 0)] < NEAR_FIX))


def observe(connect: str, robot: str, mode: str, control_on: str) -> None:
    """Stamp the chain until stdin closes, then print its stages as JSON (the observer process)."""
    bus = ZenohBus.open(connect, mode=mode, listen=PEER_LISTEN if mode == "peer" else None)
    rec = ChainRecorder(bus, robot, control_on)
    print(READY, flush=True)
    sys.stdin.read()  # the measuring process closes it to end the window
    bus.close()
    print(json.dumps(rec.stages()), flush=True)


class Observer:
    """The observer process for one robot: recording from start() until stages()."""

    def __init__(self, connect: str, robot: str, control_on: str, mode: str = "client") -> None:
        self.robot = robot
        self.args = child.argv(observe, connect, robot, mode, control_on)
        self.proc: subprocess.Popen[str] | None = None

    def start(self) -> Observer:
        """Start it; returns once it is subscribed."""
        self.proc = subprocess.Popen(self.args, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        assert self.proc.stdout is not None
        if self.proc.stdout.readline().strip() != READY:
            self.close()
            raise RuntimeError("the latency observer did not start")
        return self

    def stages(self) -> dict[str, list[float]]:
        """End the recording; per stage and end to end, the latencies [ms]."""
        assert self.proc is not None, "start() first"
        out, _ = self.proc.communicate(timeout=60.0)
        self.proc = None
        return cast(dict[str, list[float]], json.loads(out))

    def close(self) -> None:
        """Stop it if it still runs (idempotent)."""
        if self.proc is not None and self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()
        self.proc = None
