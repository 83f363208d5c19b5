"""One instance per service and robot: the ids that name instances, and the refusal of a second one.

`Service.start` refuses (`Duplicate`) when the service's token is already declared, and each instance holds
`instance/<service>/<id>`, so two that started together see each other: diag shows `error` while another runs.
"""

from __future__ import annotations

import os
import socket

from zenav.common import keys
from zenav.common.bus import Bus


class Duplicate(Exception):
    """Another instance of the service already runs for this robot."""


def instance_id() -> str:
    """host-pid-random: names one service object (several may share a process in tests)."""
    host = "".join(c if c.isalnum() or c in "-_." else "_" for c in socket.gethostname())[:40] or "host"
    return f"{host}-{os.getpid()}-{os.urandom(3).hex()}"


def running_for(bus: Bus, robot: str, service: str) -> str | None:
    """The ids of the instances of `service` that run for `robot` (its tokens), comma-separated; None: none."""
    found = bus.tokens(keys.key(robot, f"instance/{service}/*"))
    if found:
        return ", ".join(sorted(k.rsplit("/", 1)[-1] for k in found))
    if bus.tokens(keys.alive(robot, service)):  # one that holds no instance token
        return f"instance unknown: alive/{service} is held"
    return None
