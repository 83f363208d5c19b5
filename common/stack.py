"""Running a whole stack inside one process: a router and every service on its own session.

For integration tests and benchmarks: real Zenoh sessions over real loopback
sockets, one worker thread per service, no child processes.
"""
from __future__ import annotations

import socket
import threading
from typing import Iterable, Optional

import zenoh

from zenav import services as registry
from zenav.common.bus import ZenohBus, zenoh_config
from zenav.common.config import Settings
from zenav.common.keys import SERVICES
from zenav.common.runtime import Service


def free_port() -> int:
    """A TCP port on 127.0.0.1 nobody listens on now."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Router:
    """A Zenoh router in this process, listening on loopback."""

    def __init__(self, port: Optional[int] = None) -> None:
        self.endpoint = f"tcp/127.0.0.1:{port or free_port()}"
        self.session = zenoh.open(zenoh_config("router", listen=self.endpoint))

    def close(self) -> None:
        if not self.session.is_closed():
            self.session.close()

    def __enter__(self) -> Router:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class InProcessStack:
    """Services of one robot, each with its own client session to `connect`."""

    def __init__(self, settings: Settings, connect: str, services: Iterable[str] = SERVICES) -> None:
        self.settings, self.connect = settings, connect
        self.names = list(services)
        self.services: dict[str, Service] = {}
        self._threads: dict[str, threading.Thread] = {}
        self._buses: dict[str, ZenohBus] = {}

    def start(self) -> InProcessStack:
        for name in self.names:
            self.start_service(name)
        return self

    def start_service(self, name: str) -> Service:
        cls = registry.load(name)
        bus = ZenohBus.open(self.connect)
        svc = cls(self.settings, bus, cls.make_clock(self.settings))
        svc.start()
        th = threading.Thread(target=svc.run, name=f"zenav-{name}", daemon=True)
        th.start()
        self.services[name], self._threads[name], self._buses[name] = svc, th, bus
        return svc

    def stop_service(self, name: str) -> None:
        svc = self.services.pop(name)
        svc.stop()
        self._threads.pop(name).join(timeout=5.0)
        svc.close()
        self._buses.pop(name).close()

    def stop(self) -> None:
        for name in reversed(list(self.services)):
            self.stop_service(name)

    def __enter__(self) -> InProcessStack:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()
