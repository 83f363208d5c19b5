"""The worker that serves services: one thread for several services of one process, and the priority of
threads doing background work."""

from __future__ import annotations

import logging
import os
import threading
from typing import Protocol

from zenav.common.config import Limits
from zenav.common.inbox import Inbox

BACKGROUND_NICE = 10  # added to the niceness of a thread doing background work (as `nice` adds by default)


class Served(Protocol):
    """What the worker needs of a service (zenav.common.runtime.Service)."""

    background: bool
    limits: Limits
    _inbox: Inbox

    def turn(self, budget: int) -> float | None: ...


def background_thread() -> None:
    """Lower the calling thread's priority by BACKGROUND_NICE (Linux keeps niceness per thread; threads it
    starts later take it): work off the control loop's path, such as a camera's detector, then yields the
    cores to it on a computer they share. Lowering a priority needs no privilege."""
    tid = threading.get_native_id()
    try:
        os.setpriority(os.PRIO_PROCESS, tid, min(os.getpriority(os.PRIO_PROCESS, tid) + BACKGROUND_NICE, 19))
    except OSError as e:  # not Linux, or a sandbox that forbids it: the work runs at the priority it has
        logging.getLogger("zenav").warning("could not lower a background thread's priority: %s", e)


class Executor:
    """One worker thread for several services of one process (a composed deployment, as
    ROS 2's component containers run on one executor).

    The services' inboxes share one condition: input from outside wakes the worker once,
    and a message one service publishes to another in the process is taken on the same
    thread in the next round, without a thread switch (or at once on the bus's thread that
    brought it, when that service is idle: `Service.inline`). Each round gives every service a
    turn of up to ROUND items (priority lane first) and its due timers, in the order given.
    """

    ROUND = 64  # items one service dispatches before the next gets its turn
    IDLE = 0.1  # [s] wall, the longest wait without input or a timer due

    def __init__(self) -> None:
        self.services: list[Served] = []
        self._wake = threading.Condition(threading.Lock())
        self._stop = threading.Event()

    def add(self, svc: Served) -> None:
        """Take `svc` into this worker; before svc.start() (its input then queues here)."""
        svc._inbox = Inbox(svc.limits.queue_items, svc.limits.queue_bytes, ready=self._wake)
        self.services.append(svc)

    def run(self) -> None:
        """Serve the services until stop() (on this thread, lowered first if they are all `background`)."""
        if self.services and all(svc.background for svc in self.services):
            background_thread()
        while not self._stop.is_set():
            delay: float | None = None
            for svc in self.services:
                d = svc.turn(self.ROUND)
                if d is not None:
                    delay = d if delay is None else min(delay, d)
            with self._wake:
                if not self._stop.is_set() and all([svc._inbox.idle() for svc in self.services]):  # every poke taken
                    self._wake.wait(self.IDLE if delay is None else min(delay, self.IDLE))

    def stop(self) -> None:
        """End run() after the current turn (any thread)."""
        self._stop.set()
        with self._wake:
            self._wake.notify()
