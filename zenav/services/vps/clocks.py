"""The camera host's clock, synchronised to each robot's stack clock over `time/sync`, and the link's delay.

The vps runs on the camera host: frames come stamped on that host's clock. Each
SYNC_PERIOD it asks every robot it serves for its stack's clock (`zenav/<robot>/time/sync`,
the localizer answers), reading its own clock as the query goes and as the reply comes;
TimeSync (timesync.py) fits offset and drift, and fixes are stamped on that robot's
stack clock. With [camera] clock_sync = false the host is taken to be on the stack's
clock already (chrony, PTP). In the sim, the camera host's clock is the stack's set off by
[camera] clock_offset and clock_drift, as the sim stamps its frames.
"""

from __future__ import annotations

from collections import deque
from functools import partial

import numpy as np

from zenav.common import codec, keys
from zenav.common import messages as m
from zenav.common.bus import Bus
from zenav.common.clock import Clock
from zenav.common.config import Camera
from zenav.services.vps.timesync import MAX_RTT, Exchange, TimeSync
from zenav.world.camera_time import host_time

SYNC_PERIOD = 1.0  # [s] stack clock between two rounds of time/sync queries
JITTER_STREAM = 0x4A4954  # "JIT": the link delay's spread
REPLIES_HELD = 256  # replies waiting for the worker at most (one a robot a second come)
EMPTY = codec.encode(m.Empty())


class HostClock:
    """The camera host's clock; its sync to each robot's stack clock; the link delay of each fix."""

    def __init__(self, cfg: Camera, clock: Clock, bus: Bus, seed: int) -> None:
        self.cfg, self.clock, self.bus = cfg, clock, bus
        self.syncs = {robot: TimeSync() for robot in cfg.robots} if cfg.clock_sync else {}
        self._replies: deque[tuple[str, float, float, bool, bytes]] = deque(maxlen=REPLIES_HELD)  # filled on bus threads
        self.rng = np.random.default_rng([seed, JITTER_STREAM])
        self.jitter = cfg.link_jitter if cfg.model != "ideal" else 0.0  # [s] 1 sigma

    def now(self) -> float:
        """[s] the camera host's clock."""
        return host_time(self.clock.now(), self.cfg.clock_offset, self.cfg.clock_drift)

    def ask(self) -> None:
        """Send one time/sync query to every robot's stack; replies are queued until `take_replies`."""
        for robot in self.syncs:
            self.bus.request(keys.key(robot, "time/sync"), EMPTY, partial(self._reply, robot, self.now()), timeout=MAX_RTT)

    def _reply(self, robot: str, sent: float, ok: bool, data: bytes) -> None:
        """On the bus's thread: the host's clock read at once, the rest queued."""
        self._replies.append((robot, sent, self.now(), ok, data))

    def take_replies(self) -> list[str]:
        """Fit the replies that came; why each refused one was."""
        refused = []
        while self._replies:
            robot, sent, received, ok, data = self._replies.popleft()
            try:
                if not ok:
                    raise codec.BadInput(f"an error reply ({data[:80]!r})")
                why = self.syncs[robot].add(Exchange(sent, codec.decode(data, m.ClockReply).t, received))
            except codec.BadInput as e:
                why = str(e)
            if why:
                refused.append(f"{robot}: {why}")
        return refused

    def to_stack(self, robot: str, t_host: float) -> float | None:
        """[s] robot's stack clock when the host's read t_host; None: not synchronised yet."""
        if not self.cfg.clock_sync:
            return t_host
        sync = self.syncs.get(robot)
        return sync.to_stack(t_host) if sync is not None and sync.ready else None

    def forget(self) -> None:
        """The stack clock restarted: every fit is void."""
        for sync in self.syncs.values():
            sync.exchanges.clear()

    def link_delay(self) -> float:
        """[s] this fix's time on the link: [camera] link_delay, spread by link_jitter (1 sigma), never below 0."""
        spread = self.jitter * float(self.rng.standard_normal()) if self.jitter > 0.0 else 0.0
        return max(0.0, self.cfg.link_delay + spread)
