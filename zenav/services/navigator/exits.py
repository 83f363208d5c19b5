"""Why a move ended: the exit reasons, and an error band held for a time (LemLib / EZ-Template exits).

Pure: times come in as arguments. A move ends on the first of (the contract's `Exit` codes):
- `within_tolerance`: the error is under the goal's tolerance and the robot stops within it;
- `passed`: the stop is predicted past the target, outside the tolerance (it cannot get closer going on);
- `settled`: the error stayed under `settle_error` for `settle_time` (close, but no longer closing in);
- `big_error`: the error stayed under `big_error` for `big_time` (near, and stuck there);
- `timeout`: the goal's time-out ran out;
- `stalled`: no progress for `progress_timeout` (aborted at once);
- `cancelled` (nav/stop, a newer goal, the lease) or `aborted` (the pose or a service was lost);
- `chained`: a chained move (`min_speed` > 0, LemLib's motion chaining) crossed the line across its
  approach `early_exit_range` before its target, at speed: it succeeds at once, and the robot holds
  its last command for `chain_time`, for the next goal to take over without stopping.
After the first four and `timeout` the robot holds zero for `rest_time`, then the error is
re-checked: `succeeded` only if it is within the tolerance. A move that stopped at its target
(`within_tolerance`, `passed`) but is found over it (a late VPS fix moved the pose) moves again,
`retries` times at most (turning to face the point first when it lies off the heading line); else it
ends `aborted`, saying by how much.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class Hold:
    """An error band that must be held for `time` [s]: since when the error has stayed inside it."""

    time: float  # [s]
    since: float | None = None  # [s] pose t the error entered the band (None: outside)

    def update(self, t: float, inside: bool) -> bool:
        """Whether the error, inside the band or not at t [s], has now been held inside for `time`."""
        if not inside:
            self.since = None
            return False
        if self.since is None:
            self.since = t
        return t - self.since >= self.time

    def reset(self) -> None:
        """Forget the time held (a new target)."""
        self.since = None
