"""Where each goal stands, from the navigator's nav/state messages alone.

Pure: the messages come in, in the order the navigator published them; a goal's
newest state and its end come out. The navigator publishes on every change of
(state, goal id, result), so a goal's end is either its own state with a result,
or a state of a newer goal (it was preempted: `cancelled`). Goal ids count from 1
again when a navigator restarts: `forget` then.
"""

from __future__ import annotations

from dataclasses import dataclass

from zenav.common import messages as m
from zenav.common.contract import Exit, GoalResult, State

KEEP_GOALS = 64  # goal ids remembered below the newest


@dataclass(frozen=True)
class GoalEnd:
    """How a goal ended, as nav/state showed it."""

    result: str  # succeeded, cancelled, aborted
    message: str  # the navigator's words ("arrived", "preempted by goal 4", ...)
    elapsed: float | None  # [s] stack clock from its start to its end; None if either was not seen
    exit: str | None = None  # why its move ended (within_tolerance, settled, timeout, cancelled...); None if unknown


class GoalTracker:
    """The newest nav/state of each recent goal, and the goals' ends."""

    def __init__(self, keep: int = KEEP_GOALS) -> None:
        self.keep = keep
        self.newest: m.NavState | None = None
        self._states: dict[int, m.NavState] = {}  # goal id -> its newest nav/state
        self._starts: dict[int, float] = {}  # goal id -> [s] stack clock at its start

    def on_state(self, st: m.NavState) -> None:
        """Take a nav/state message."""
        self.newest = st
        self._states[st.goal_id] = st
        if st.result is None and st.state != State.STOPPED:
            self._starts.setdefault(st.goal_id, st.t - st.elapsed)
        for gid in [g for g in self._states if g <= st.goal_id - self.keep]:
            del self._states[gid]
            self._starts.pop(gid, None)

    def forget(self) -> None:
        """The navigator went: a new one counts goals from 1 again."""
        self.newest = None
        self._states.clear()
        self._starts.clear()

    def state(self, goal_id: int) -> m.NavState | None:
        """The newest nav/state of a goal, or None if none was seen."""
        return self._states.get(goal_id)

    def current(self, goal_id: int) -> bool:
        """Whether no newer goal than this one was seen."""
        return self.newest is None or self.newest.goal_id <= goal_id

    def end(self, goal_id: int) -> GoalEnd | None:
        """How the goal ended, or None while it may still run."""
        st = self._states.get(goal_id)
        if st is not None and st.result is not None:
            return GoalEnd(st.result, st.message, self._elapsed(goal_id, st.t), st.exit)
        if not self.current(goal_id):
            later = goal_id + 1  # ids count up by one: the goal that preempted this one
            end_t = self._starts.get(later)
            return GoalEnd(GoalResult.CANCELLED, f"preempted by goal {later}", self._elapsed(goal_id, end_t), Exit.CANCELLED)
        return None

    def _elapsed(self, goal_id: int, end_t: float | None) -> float | None:
        start_t = self._starts.get(goal_id)
        return None if start_t is None or end_t is None else max(end_t - start_t, 0.0)
