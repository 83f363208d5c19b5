"""Sending a goal to a stack of separate processes on a shared, sometimes stalled host."""
from __future__ import annotations

import time

from zenav.common.client import Client, ClientError

ATTEMPTS = 3  # goals tried before a stale pose counts as a failure


def stale(text: str) -> bool:
    return "pose stale" in text


def next_pose(watcher: Client, timeout: float) -> None:
    """Block until a pose newer than the newest one now arrives."""
    newest = watcher.latest("pose").wait(timeout=timeout)
    watcher.latest("pose").wait(lambda p, t=newest.t: p.t > t, timeout=timeout)


def wait_ready(operator: Client, watcher: Client, timeout: float) -> None:
    """Block until the navigator would take a goal (a fresh pose, VPS fixes in), asking on each new pose."""
    deadline = time.monotonic() + timeout
    while True:
        why = operator.query("nav/status", timeout=timeout).not_ready
        if not why:
            return
        assert time.monotonic() < deadline, f"navigator not ready after {timeout} s: {why}"
        next_pose(watcher, timeout)


def move_to_point(operator: Client, watcher: Client, x: float, y: float, timeout: float):
    """A move_to_point with wait, once the navigator is ready; the reply.

    When the host stalls the stack (six processes starting on two cores), the
    navigator rightly refuses or aborts a goal on a stale pose. That is retried
    once the next pose arrives, at most ATTEMPTS times in all; anything else is
    returned or raised as it came.
    """
    wait_ready(operator, watcher, timeout)
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
        next_pose(watcher, timeout)
    raise AssertionError("unreachable")
