"""The overhead VPS camera: samples the truth, adds the scenario's errors, delays delivery.

Pure: the truth comes in as messages, time is the truth's t, randomness from the
generator passed in. Every capture draws the same number of random values whatever
happens to it, so one seed gives one stream of fixes.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass, field

import numpy as np

from zenav.common import messages as m
from zenav.common.geometry import wrap_angle
from zenav.common.scenarios import Scenario
from zenav.world import faults

# Seed stream of the camera, mixed with the deployment seed so that its draws
# differ from the robot's generators (numpy SeedSequence entropy words).
RNG_STREAM = 0x565053  # "VPS"


def make_rng(seed: int) -> np.random.Generator:
    """The camera's generator for a deployment seed."""
    return np.random.default_rng([seed, RNG_STREAM])


@dataclass(frozen=True, order=True)
class Delivery:
    """One fix and when it reaches the stack."""

    t_delivery: float  # [s] stack clock
    seq: int  # capture number: orders equal delivery times
    fix: m.VpsPose = field(compare=False)
    outlier: bool = field(compare=False, default=False)  # displaced on purpose (for tests)


class Camera:
    """Captures fixes from truth samples at the scenario's rate, with its errors."""

    def __init__(self, scenario: Scenario, rng: np.random.Generator) -> None:
        self.sc = scenario
        self.rng = rng
        self.period = 1.0 / scenario.vps_rate_hz  # [s]
        self._next: float | None = None  # [s] time of the next capture
        self._seq = 0
        var_xy = scenario.vps_noise_xy**2
        var_th = math.radians(scenario.vps_noise_theta_deg) ** 2
        self.cov = (var_xy, 0.0, 0.0, 0.0, var_xy, 0.0, 0.0, 0.0, var_th)

    def capture(self, truth: m.Truth) -> Delivery | None:
        """The fix taken at this truth sample, if one is due and not lost."""
        t = truth.t
        # Stay on the rate's grid; restart it at the first sample, after a gap, or
        # when time went backwards (the sim restarted).
        if self._next is None or not self._next - self.period <= t < self._next + self.period:
            self._next = t
        if t < self._next - 1e-6:  # tolerance: sample times are sums of floats
            return None
        self._next += self.period
        self._seq += 1
        drop, outlier, direction, jitter = (float(u) for u in self.rng.random(4))
        nx, ny, nth = (float(n) for n in self.rng.standard_normal(3))
        if drop < self.sc.vps_drop or faults.vps_outage(self.sc, t):
            return None
        x = truth.x + nx * self.sc.vps_noise_xy
        y = truth.y + ny * self.sc.vps_noise_xy
        is_outlier = outlier < self.sc.vps_outlier
        if is_outlier:
            a = 2.0 * math.pi * direction
            x += self.sc.vps_outlier_dist * math.cos(a)
            y += self.sc.vps_outlier_dist * math.sin(a)
        theta = wrap_angle(truth.theta + nth * math.radians(self.sc.vps_noise_theta_deg))
        latency = max(self.sc.vps_latency + (2.0 * jitter - 1.0) * self.sc.vps_jitter, 0.0)
        fix = m.VpsPose(t=t, x=x, y=y, theta=theta, cov=self.cov)
        return Delivery(t + latency, self._seq, fix, is_outlier)


class DeliveryQueue:
    """Fixes waiting for their delivery time (out of order when the jitter says so)."""

    def __init__(self) -> None:
        self._heap: list[Delivery] = []

    def __len__(self) -> int:
        return len(self._heap)

    def push(self, d: Delivery) -> None:
        """Hold a fix until its delivery time."""
        heapq.heappush(self._heap, d)

    def pop_due(self, now: float) -> list[Delivery]:
        """Every fix whose delivery time has come, in delivery order."""
        out = []
        while self._heap and self._heap[0].t_delivery <= now:
            out.append(heapq.heappop(self._heap))
        return out

    def clear(self) -> None:
        """Forget every pending fix."""
        self._heap.clear()
