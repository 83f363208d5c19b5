"""The report's sections as markdown lines, from the bench's results: a module per group of sections."""

from zenav.bench.tables.driving import accuracy, camera, navigation, settle
from zenav.bench.tables.load import cost, fleet, profile, speed
from zenav.bench.tables.markdown import fmt, table
from zenav.bench.tables.timing import TARGET_ADDED, latency, ratios

__all__ = [  # what the report reads
    "TARGET_ADDED",
    "accuracy",
    "camera",
    "cost",
    "fleet",
    "fmt",
    "latency",
    "navigation",
    "profile",
    "ratios",
    "settle",
    "speed",
    "table",
]
