"""Sending a goal to a stack of separate processes on a shared, sometimes stalled host, with the robot library."""

from __future__ import annotations

from zenav.common.client import Client
from zenav.robot import Result, Robot

ATTEMPTS = 3  # goals tried before an abort on a stale pose counts as a failure
# [m] These tests are about faults, security and deployment, not precision: the navigator's
# final re-check judges a fused pose that late VPS fixes move by a centimetre or two.
TOLERANCE = 0.03


def wait_ready(client: Client, timeout: float) -> None:
    """Block until the navigator would take a goal (Robot.wait_ready, on the client's session)."""
    with Robot(client.robot, bus=client.bus, lease=False) as bot:
        bot.wait_ready(timeout)


def move_to_point(client: Client, x: float, y: float, timeout: float) -> Result:
    """Go to (x, y) once the navigator is ready, on the client's session; the Result.

    When the host stalls the stack (six processes starting on two cores), the
    navigator rightly refuses or aborts a goal on a stale pose. The library sends a
    refused goal again on a fresh pose; an aborted one is tried again here once the
    navigator is ready, at most ATTEMPTS times in all.
    """
    with Robot(client.robot, bus=client.bus, timeout=timeout) as bot:
        bot.wait_ready(timeout)
        for attempt in range(1, ATTEMPTS + 1):
            result = bot.move_to_point(x, y, tolerance=TOLERANCE).wait(timeout)
            if attempt == ATTEMPTS or result.result != "aborted" or "pose stale" not in result.message:
                return result
            print(f"goal attempt {attempt}: {result.message}; trying again on a fresh pose")
            bot.wait_ready(timeout)
    raise AssertionError("unreachable")
