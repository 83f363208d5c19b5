"""Sending a goal to a stack of separate processes on a shared, sometimes stalled host."""
from __future__ import annotations

from zenav.common.client import Client, ClientError

ATTEMPTS = 3  # goals tried before a stale pose counts as a failure


def stale(text: str) -> bool:
    return "pose stale" in text


def move_to_point(operator: Client, watcher: Client, x: float, y: float, timeout: float):
    """A move_to_point with wait; the reply.

    When the host stalls the stack (six processes starting on two cores), the
    navigator rightly refuses or aborts a goal on a stale pose. That is retried
    once the next pose arrives, at most ATTEMPTS times in all; anything else is
    returned or raised as it came.
    """
    for attempt in range(1, ATTEMPTS + 1):
        try:
            reply = operator.query("nav/move_to_point", {"x": x, "y": y, "wait": True}, timeout=timeout)
        except ClientError as e:
            if attempt == ATTEMPTS or e.code != "unavailable" or not stale(e.message):
                raise
        else:
            if attempt == ATTEMPTS or reply.result != "aborted" or not stale(reply.message):
                return reply
        print(f"goal attempt {attempt}: pose stale, trying again on a fresh pose")
        newest = watcher.latest("pose").wait(timeout=timeout)
        watcher.latest("pose").wait(lambda p, t=newest.t: p.t > t, timeout=timeout)  # the next one
    raise AssertionError("unreachable")
