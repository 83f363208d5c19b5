"""The navigator's request bookkeeping: the goal waiting for its lease, the running one, the waiters.

Pure: no bus, no clock; times come in as arguments. A request with a `lease` waits
(`pending`) until its token is seen alive or its deadline passes; one without starts
at once. A request that asked to `wait` is answered when its goal ends. The service
owns the replies and the token watches: each method returns the requests it must
answer or release.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from zenav.services.navigator.goals import Goal

START, LOST = "start", "lost"  # what a lease event means for its request


@dataclass(eq=False)
class Request:
    """A goal request, resolved: what to run, how to answer, and its lease."""

    goal: Goal
    info: dict[str, Any]  # the `goal` map of nav/state
    wait: bool  # answer when the goal ends, not when it starts
    reply_to: Any  # the query to answer (opaque here)
    lease: str | None = None  # liveliness token key the goal hangs on
    watch: Any = None  # the token watch, released by the service
    deadline: float = 0.0  # [s] clock time the lease must be seen alive by
    goal_id: int = 0  # once started
    detours: int = 0  # points the planner added between the asked ones


class Requests:
    """Which request waits for its lease, which runs, and which wait for their goal's end."""

    def __init__(self) -> None:
        self.pending: Request | None = None  # waiting to see its lease token
        self.running: Request | None = None  # the running goal's request
        self.waiters: dict[int, Request] = {}  # goal id -> request answered when it ends

    def hold(self, request: Request, lease: str, deadline: float) -> Request | None:
        """Keep `request` until its lease is seen or `deadline` [s]; returns the pending one it supersedes."""
        old, self.pending = self.pending, request
        request.lease, request.deadline = lease, deadline
        return old

    def take_pending(self) -> Request | None:
        """Forget the pending request (superseded, cancelled...) and return it."""
        old, self.pending = self.pending, None
        return old

    def expired(self, now: float) -> Request | None:
        """The pending request, taken, if its lease was not seen by its deadline."""
        p = self.pending
        if p is not None and now >= p.deadline:
            self.pending = None
            return p
        return None

    def on_lease(self, request: Request, alive: bool) -> str | None:
        """A token event of `request`'s lease: START (take it: it may start), LOST (abort its goal) or None."""
        if alive and request is self.pending:
            self.pending = None
            return START
        if not alive and request is self.running and request.goal_id:
            return LOST
        return None

    def started(self, request: Request, goal_id: int) -> None:
        """`request`'s goal runs now as `goal_id`."""
        request.goal_id, self.running = goal_id, request
        if request.wait:
            self.waiters[goal_id] = request

    def ended(self, goal_id: int) -> tuple[Request | None, Request | None]:
        """Goal `goal_id` ended: (its request if it was running, to release; the waiter to answer)."""
        r = self.running
        done = None
        if r is not None and r.goal_id == goal_id:
            done, self.running = r, None
        return done, self.waiters.pop(goal_id, None)
