"""Running a whole stack inside one process: every service on its own session.

For integration tests and benchmarks: real Zenoh sessions over real loopback
sockets (to a `stack.router.Router`), one worker thread per service, no child processes.
"""

from __future__ import annotations

import socket
import threading
from collections.abc import Iterable

from zenav import services as registry
from zenav.common.bus import ZenohBus
from zenav.common.config import Settings
from zenav.common.runtime import Service

JOIN_TIMEOUT = 5.0  # [s] a service's worker thread gets this long to end after stop


def free_port() -> int:
    """A TCP port on 127.0.0.1 nobody listens on now."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class InProcessStack:
    """Services of one robot, each with its own client session to `connect`."""

    def __init__(self, settings: Settings, connect: str, services: Iterable[str] = registry.NAMES) -> None:
        self.settings, self.connect = settings, connect
        self.names = list(services)
        self.services: dict[str, Service] = {}
        self._threads: dict[str, threading.Thread] = {}
        self._buses: dict[str, ZenohBus] = {}

    def start(self) -> InProcessStack:
        """Start every named service, in the order given."""
        for name in self.names:
            self.start_service(name)
        return self

    def start_service(self, name: str) -> Service:
        """Start one service on its own session and worker thread."""
        cls = registry.load(name)
        bus = ZenohBus.open(self.connect)
        svc = cls(self.settings, bus, cls.make_clock(self.settings))
        svc.inline = True
        svc.start()
        th = threading.Thread(target=svc.run, name=f"zenav-{name}", daemon=True)
        th.start()
        self.services[name], self._threads[name], self._buses[name] = svc, th, bus
        return svc

    def stop_service(self, name: str) -> None:
        """Stop one running service and close its session."""
        svc = self.services.pop(name)
        svc.stop()
        self._threads.pop(name).join(timeout=JOIN_TIMEOUT)
        svc.close()
        self._buses.pop(name).close()

    def stop(self) -> None:
        """Stop every running service in the registry's stop order."""
        for name in registry.stop_order(self.services):
            self.stop_service(name)

    def __enter__(self) -> InProcessStack:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()
