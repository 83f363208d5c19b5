"""One service on the in-memory bus with a manual clock, for service tests.

    from tests.support.rig import Rig

    rig = Rig(Motor, t0=10.0, motor={"max_wheel_accel": 40.0})  # sections as Settings.load overrides
    rig.put("cmd_vel", m.CmdVel(t=rig.t, v=0.1, omega=0.0))       # publish, then drain the service
    rig.advance(0.01)                                              # clock += dt, drain; returns the new t
    rig.run(1.0, dt=0.01)                                          # advance in steps of dt
    rig.got("motors/wheels")                                       # -> [m.Wheels, ...] published so far
    q = rig.query("nav/stop", payload=None, params=None)           # -> the MemoryQuery, after draining
    rig.reply(q)                                                   # -> its one reply, decoded (or m.ErrorReply)
    rig.drain()                                                    # process the queue and due timers
    rig.close()                                                    # or use `with Rig(...) as rig:`

`rig.svc`, `rig.bus` and `rig.clock` stay reachable for anything else.
"""

from __future__ import annotations

from typing import Any, Generic, TypeVar

from zenav.common import codec, keys
from zenav.common import messages as m
from zenav.common.bus import MemoryBus, MemoryQuery
from zenav.common.clock import Clock, ManualClock
from zenav.common.config import Settings
from zenav.common.runtime import Service

S = TypeVar("S", bound=Service)


class Rig(Generic[S]):
    """A started service of type `service`, its MemoryBus and its clock."""

    def __init__(self, service: type[S], t0: float = 0.0, clock: Clock | None = None, **sections: dict) -> None:
        self.bus = MemoryBus()
        self.clock: Any = clock if clock is not None else ManualClock(t0)
        self.svc: S = service(Settings.load(None, **sections), self.bus, self.clock)
        self.robot = self.svc.robot
        self.svc.start()
        self.svc.drain()

    @property
    def t(self) -> float:
        """Now on the rig's clock."""
        return self.clock.now()

    def key(self, suffix: str) -> str:
        """The full key of a contract suffix for the rig's robot."""
        return keys.key(self.robot, suffix)

    def put(self, suffix: str, msg: Any) -> None:
        """Publish `msg` (a Struct, or any msgpack-able value) on the topic, then drain."""
        self.bus.publish(self.key(suffix), msg if isinstance(msg, bytes) else codec.encode(msg))
        self.svc.drain()

    def got(self, suffix: str) -> list:
        """Every message published on the topic so far, decoded with its contract type."""
        full, typ = self.key(suffix), keys.TOPICS[suffix]
        return [codec.decode(d, typ) for k, d in self.bus.published if k == full]

    def query(self, suffix: str, payload: Any = None, params: dict[str, str] | None = None) -> MemoryQuery:
        """Send a query (payload encoded unless None or bytes), drain, return it with its replies."""
        data = b"" if payload is None else payload if isinstance(payload, bytes) else codec.encode(payload)
        q = self.bus.query(self.key(suffix), data, params)
        self.svc.drain()
        return q

    def reply(self, q: MemoryQuery) -> Any:
        """The one finished reply of `q`, decoded: the contract reply type, or ErrorReply."""
        assert q.finished and len(q.replies) == 1, f"expected one finished reply, got {q.replies} (finished={q.finished})"
        [(ok, data)] = q.replies
        suffix = q.key.removeprefix(self.key(""))
        return codec.decode(data, keys.QUERIES[suffix][1] if ok else m.ErrorReply)

    def drain(self) -> int:
        """Process every queued input and due timer; returns how many inputs ran."""
        return self.svc.drain()

    def advance(self, dt: float) -> float:
        """Move the manual clock on by `dt` [s] and drain; returns the new time."""
        t = self.clock.advance(dt)
        self.svc.drain()
        return t

    def run(self, seconds: float, dt: float = 0.01) -> float:
        """Advance the clock in steps of `dt` [s] for `seconds`, draining after each."""
        for _ in range(round(seconds / dt)):
            self.advance(dt)
        return self.t

    def close(self) -> None:
        """Close the service (on_stop, token and declarations withdrawn)."""
        self.svc.close()

    def __enter__(self) -> Rig[S]:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
