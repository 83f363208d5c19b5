"""What the robot services add to sensor-to-wheel latency: the stack against its relay arm.

Each latency run measures the stack and, on the same router over the same window, the
relay arm (bench/arm.py: the same stack with odometry, localizer, navigator and motor
replaced in place by relays); the arms' samples interleave in time, so the host's load
weighs on both alike. Over several runs of a deployment, the samples of each arm are
pooled: added latency at p50 and p99 is the stack's end-to-end percentile minus the
arm's. Its confidence interval is a bootstrap: each run's samples of each arm drawn again
with replacement (runs kept apart), the difference taken per draw. Samples next to each
other in time are not independent, so the interval is narrower than a truth that would
count that; more runs, not more samples, widen it honestly.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from zenav.bench.latency import END_TO_END

DRAWS = 1000  # bootstrap draws
LEVEL = 0.95  # the interval's confidence
SEED = 1  # the bootstrap's generator (a report is reproducible from its samples)
QS = (50.0, 99.0)  # the percentiles reported


@dataclass(frozen=True)
class Added:
    """One deployment's added latency [ms] at QS, each with its interval, over `runs` runs."""

    runs: int
    n: tuple[int, int]  # samples pooled: the stack's, the arm's
    stack: tuple[float, float]  # the stack's end to end at QS
    arm: tuple[float, float]  # the relay arm's end to end at QS
    added: tuple[float, float]  # the stack's less the arm's, at QS
    low: tuple[float, float]  # the interval's ends per percentile
    high: tuple[float, float]

    def line(self, deployment: str) -> str:
        """`services' added latency, clients: p50 0.21 ms (0.18 to 0.24), p99 0.80 ms (0.52 to 1.10); ...`."""
        parts = [f"p{q:g} {a:.2f} ms ({lo:.2f} to {hi:.2f})" for q, a, lo, hi in zip(QS, self.added, self.low, self.high)]
        return (
            f"services' added latency, {deployment}: {', '.join(parts)}; stack {self.stack[0]:.2f} / {self.stack[1]:.2f} ms, "
            f"relay arm {self.arm[0]:.2f} / {self.arm[1]:.2f} ms (p50 / p99), {self.runs} runs, {self.n[0]} / {self.n[1]} samples"
        )


def measure(stack: Sequence[Sequence[float]], arm: Sequence[Sequence[float]], draws: int = DRAWS, seed: int = SEED) -> Added:
    """Added latency from per-run end-to-end samples [ms] of the stack and of its relay arm (run i of each: one window)."""
    if len(stack) != len(arm) or not stack:
        raise ValueError("one list of samples per run, for the stack and for the arm alike")
    runs_s, runs_a = [np.asarray(s, dtype=float) for s in stack], [np.asarray(a, dtype=float) for a in arm]
    if any(len(x) == 0 for x in (*runs_s, *runs_a)):
        raise ValueError("a run without samples")
    pooled_s, pooled_a = np.concatenate(runs_s), np.concatenate(runs_a)
    ps, pa = np.percentile(pooled_s, QS), np.percentile(pooled_a, QS)
    rng = np.random.default_rng(seed)
    diffs = np.empty((draws, len(QS)))
    for k in range(draws):
        ds = np.concatenate([rng.choice(x, size=len(x)) for x in runs_s])
        da = np.concatenate([rng.choice(x, size=len(x)) for x in runs_a])
        diffs[k] = np.percentile(ds, QS) - np.percentile(da, QS)
    tail = (1.0 - LEVEL) / 2.0 * 100.0
    low, high = np.percentile(diffs, tail, axis=0), np.percentile(diffs, 100.0 - tail, axis=0)

    def pair(v: np.ndarray) -> tuple[float, float]:
        return float(v[0]), float(v[1])

    return Added(len(stack), (len(pooled_s), len(pooled_a)), pair(ps), pair(pa), pair(ps - pa), pair(low), pair(high))


def of_runs(chains: Sequence[dict[str, list[float]]], arms: Sequence[dict[str, list[float]]]) -> Added:
    """Added latency from the runs' chains (the observer's stages) and their arms'."""
    return measure([c[END_TO_END] for c in chains], [a[END_TO_END] for a in arms])


def pooled(chains: Sequence[dict[str, list[float]]]) -> dict[str, list[float]]:
    """Several runs' stages as one: their samples together, stage by stage."""
    return {name: [x for c in chains for x in c[name]] for name in chains[0]}
