"""The other robots on the field as last heard: each one's newest report, forgotten when it falls silent.

Every robot sends its body on a field topic that its own services also hear; the motor's guard, the navigator and
the sim each keep the others' newest, and a robot not heard again within `kept` seconds is gone (its stack stopped).
"""

from __future__ import annotations

from typing import Generic, TypeVar

T = TypeVar("T")


class Others(Generic[T]):
    """The newest report of each robot but this one, kept for `kept` seconds of the caller's clock."""

    def __init__(self, own: str, kept: float) -> None:
        self.own, self.kept = own, kept
        self._last: dict[str, tuple[float, T]] = {}  # robot -> (time heard, its report)

    def heard(self, robot: str, now: float, report: T) -> None:
        """A robot's report at time `now` (this robot's own is not kept)."""
        if robot != self.own:
            self._last[robot] = (now, report)

    def at(self, now: float) -> dict[str, T]:
        """Each robot heard within `kept` of `now`; the others are forgotten."""
        for robot in [r for r, (heard, _) in self._last.items() if now - heard > self.kept]:
            del self._last[robot]
        return {r: report for r, (_, report) in self._last.items()}
