"""Sensor-to-wheel latency through the stack, stage by stage, on the host's wall clock.

Every message of the chain carries the t of the encoder sample it descends from, and
the sim stamps the `sim/truth` message of that t with its wall clock, taken just
before it publishes the sample. An observer subscribed to the chain stamps each arrival. For
each t, end to end = arrival of `motors/wheels` - the sim's stamp (now - t on
motors/wheels at a realtime factor of 1), and it splits exactly into: delivery (sim
to a subscriber: one hop, the observer's own), then per service the hop into it plus
its work (its output's arrival - its input's arrival).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from zenav.common import messages as m
from zenav.common.client import Client

CHAIN = ("sensors/encoders", "odom", "pose", "cmd_vel", "motors/wheels")  # sim -> odometry -> ... -> motor
STAGES = ("delivery", "odometry", "localizer", "navigator", "motor")  # what ends with each chain message
END_TO_END = "end to end"


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
    """Stamps the wall arrival of each chain message of one robot, by t, while recording."""

    def __init__(self, client: Client) -> None:
        self._lock = threading.Lock()
        self.recording = False
        self.stamp: dict[float, float] = {}  # t -> sim's wall clock at t [s]
        self.arrival: dict[str, dict[float, float]] = {topic: {} for topic in CHAIN}  # topic -> t -> wall [s]
        client.subscribe("sim/truth", self._on_truth)
        for topic in CHAIN:
            client.subscribe(topic, self._stamper(topic))

    def _on_truth(self, msg: m.Truth) -> None:
        if self.recording:
            with self._lock:
                self.stamp[msg.t] = msg.wall

    def _stamper(self, topic: str):
        table = self.arrival[topic]

        def on_msg(msg) -> None:
            now = time.time()  # before anything else: the arrival as this process sees it
            if self.recording:
                with self._lock:
                    table.setdefault(msg.t, now)  # the first: a watchdog stop repeats a t

        return on_msg

    def stages(self) -> dict[str, list[float]]:
        """Per stage and end to end, the latencies [ms] of every t that went all the way through."""
        with self._lock:
            ts = [t for t in self.arrival[CHAIN[-1]] if t in self.stamp and all(t in self.arrival[c] for c in CHAIN)]
            times = np.array([[self.stamp[t]] + [self.arrival[c][t] for c in CHAIN] for t in ts]).reshape(-1, len(CHAIN) + 1)
        steps = np.diff(times, axis=1) * 1e3  # [ms] column k: chain[k] arrival - the one before
        out = {stage: steps[:, k].tolist() for k, stage in enumerate(STAGES)}
        out[END_TO_END] = ((times[:, -1] - times[:, 0]) * 1e3).tolist()
        return out
