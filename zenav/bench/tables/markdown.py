"""Markdown for the report: figures, percentages, tables and rows of latency statistics."""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import Any

from zenav.bench.latency import Stats


def fmt(x: float, digits: int = 2) -> str:
    return "-" if math.isnan(x) else f"{x:.{digits}f}"


def pct(x: float) -> str:
    return "-" if math.isnan(x) else f"{x:.0%}"


def table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> list[str]:
    """A markdown table."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return lines + ["| " + " | ".join(map(str, r)) + " |" for r in rows]


def stats_row(name: str, values: Sequence[float]) -> list[str]:
    st = Stats.of(values)
    return [name, str(st.n), fmt(st.p50), fmt(st.p90), fmt(st.p99), fmt(st.max)]


def failures(labelled: Iterable[tuple[str, Any]]) -> list[str]:
    """A line per run with goals that did not succeed, and why."""
    out = [f"- {label}: {'; '.join(s.failures)}" for label, s in labelled if s.failures]
    return ["", "Goals that did not succeed:", *out] if out else []
