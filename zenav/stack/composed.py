"""Several services in one process (a small computer's deployment), each still its own service.

`LocalBus` delivers between the services of the process directly (the publisher's
thread calls the subscribers' enqueue: no socket, no router) and to and from the
rest of the stack through one shared Zenoh session: a sample published here reaches
the local subscribers once (directly) and the network once (the session's
publishers send only to remote subscribers, its subscribers take only remote
samples). Queries, liveliness tokens and their watchers go through the session.
`ComposedStack` runs named services of one robot this way on one worker thread
(runtime.Executor), each service with its own config section, diag, counters and
liveliness token: a sample from outside runs the chain through the process on the
thread that brought it while the services are idle (runtime.Service.inline), on the
worker otherwise, without a thread switch either way. A `blocking` service (the
driver waits on its serial link, the vps detects camera frames) gets a worker of its
own instead, so that its waits hold up no other service.
"""

from __future__ import annotations

import argparse
import sys
import threading
from collections.abc import Iterable, Sequence

import zenoh

from zenav import services as registry
from zenav.common.app import (
    LOG_HELP,
    PEER_LISTEN,
    deployment_args,
    realtime,
    settings_from_args,
    setup_logging,
    stop_on_signals,
    watch_parent,
)
from zenav.common.bus import (
    MSGPACK,
    Handle,
    MemoryBus,
    Newest,
    QueryCallback,
    ReplyCallback,
    SampleCallback,
    Subscribed,
    TokenCallback,
    ZenohBus,
)
from zenav.common.config import ConfigError, Settings
from zenav.common.roles import CONTROL_LOOP, start_order
from zenav.common.runtime import Duplicate, Executor, Service
from zenav.services.navigator.params import Params

JOIN_TIMEOUT = 5.0  # [s] the worker thread gets this long to end after stop
_MSGPACK = zenoh.Encoding(MSGPACK)


class _Local:
    """A subscription of one service: undeclaring it withdraws its local and network halves."""

    def __init__(self, bus: LocalBus, key: str, entry: tuple[zenoh.KeyExpr, SampleCallback]) -> None:
        self._bus, self._key, self._entry = bus, key, entry

    def undeclare(self) -> None:
        self._bus._drop(self._key, self._entry)


class _Remote:
    """One Zenoh subscriber per key expression, fanning remote samples out to every local callback on it."""

    def __init__(self, session: zenoh.Session, key: str) -> None:
        self.callbacks: tuple[SampleCallback, ...] = ()

        def on_sample(s: zenoh.Sample) -> None:
            key, data = str(s.key_expr), s.payload.to_bytes()
            for cb in self.callbacks:
                cb(key, data)

        handler = zenoh.handlers.Callback(on_sample, indirect=False)  # arrival order, as ZenohBus
        self.handle = session.declare_subscriber(key, handler, allowed_origin=zenoh.Locality.REMOTE)


class LocalBus:
    """Direct delivery between the services of one process; `rest` carries queries and tokens.

    `rest` a ZenohBus: samples also go to and come from the network through its session;
    a MemoryBus: the process is the whole world (profiling, tests)."""

    def __init__(self, rest: ZenohBus | MemoryBus) -> None:
        self.rest = rest
        self.net = rest if isinstance(rest, ZenohBus) else None
        self._subs: list[tuple[zenoh.KeyExpr, SampleCallback]] = []
        self._routes: dict[str, tuple[SampleCallback, ...]] = {}  # key -> local callbacks (rebuilt on change)
        self._pubs: dict[str, zenoh.Publisher] = {}
        self._remote: dict[str, _Remote] = {}  # key expression -> its one network subscriber
        self._lock = threading.Lock()

    def publish(self, key: str, data: bytes) -> None:
        route = self._routes.get(key)
        if route is None:
            route = self._route(key)
        for cb in route:
            cb(key, data)
        if self.net is not None:
            pub = self._pubs.get(key)
            if pub is None:
                pub = self._publisher(key)
            pub.put(data)

    def _route(self, key: str) -> tuple[SampleCallback, ...]:
        ke = zenoh.KeyExpr(key)
        with self._lock:
            route = self._routes[key] = tuple(cb for expr, cb in self._subs if expr.intersects(ke))
        return route

    def _publisher(self, key: str) -> zenoh.Publisher:
        assert self.net is not None
        with self._lock:
            pub = self._pubs.get(key)
            if pub is None:  # the same settings as ZenohBus.publish, to remote subscribers only
                pub = self._pubs[key] = self.net.session.declare_publisher(
                    key,
                    encoding=_MSGPACK,
                    congestion_control=zenoh.CongestionControl.BLOCK,
                    express=True,
                    allowed_destination=zenoh.Locality.REMOTE,
                )
        return pub

    def subscribe(self, key: str, callback: SampleCallback) -> Handle:
        entry = (zenoh.KeyExpr(key), callback)
        with self._lock:
            self._subs.append(entry)
            self._routes = {}
            if self.net is not None:
                remote = self._remote.get(key)
                if remote is None:
                    remote = self._remote[key] = _Remote(self.net.session, key)
                remote.callbacks = (*remote.callbacks, callback)
        return _Local(self, key, entry)

    def _drop(self, key: str, entry: tuple[zenoh.KeyExpr, SampleCallback]) -> None:
        with self._lock:
            if entry not in self._subs:
                return
            self._subs.remove(entry)
            self._routes = {}
            remote = self._remote.get(key)
            if remote is not None:
                rest = list(remote.callbacks)
                rest.remove(entry[1])
                remote.callbacks = tuple(rest)
                if not rest:
                    remote.handle.undeclare()
                    del self._remote[key]

    def newest(self, key: str) -> Newest:
        """The newest sample of `key`, from a service of this process or from the network: kept as it comes, unserved."""
        return Subscribed(self, key)

    def queryable(self, key: str, callback: QueryCallback, urgent: bool = False) -> Handle:
        return self.rest.queryable(key, callback, urgent)

    def request(self, key: str, payload: bytes, callback: ReplyCallback, timeout: float = 1.0) -> None:
        self.rest.request(key, payload, callback, timeout)

    def token(self, key: str) -> Handle:
        return self.rest.token(key)

    def watch_tokens(self, key: str, callback: TokenCallback) -> Handle:
        return self.rest.watch_tokens(key, callback)

    def tokens(self, key: str, timeout: float = 2.0) -> list[str]:
        return self.rest.tokens(key, timeout)

    def close(self) -> None:
        with self._lock:
            self._subs.clear()
            self._routes = {}
            for remote in self._remote.values():
                remote.handle.undeclare()
            self._remote.clear()
        for pub in self._pubs.values():
            pub.undeclare()
        self._pubs.clear()
        self.rest.close()


class ComposedStack:
    """Services of one robot in this process on one LocalBus over one session (settings' connect and Zenoh mode):
    one worker for them all, and one of its own for each `blocking` service (a serial link, camera frames)."""

    def __init__(self, settings: Settings, services: Iterable[str]) -> None:
        self.settings = settings
        control_on = settings.section("navigator", Params).control_on
        self.names = [n for n in start_order(control_on) if n in set(services)]  # the chain's services first
        self.bus: LocalBus | None = None
        self.services: dict[str, Service] = {}
        self.executors: dict[str, Executor] = {"composed": Executor()}  # worker thread name -> its executor
        self._threads: list[threading.Thread] = []

    def start(self) -> ComposedStack:
        """Open the session, start every named service, then the workers (Duplicate: the ones started are stopped again)."""
        dep = self.settings.deployment
        listen = PEER_LISTEN if dep.zenoh_mode == "peer" else None
        self.bus = LocalBus(ZenohBus.open(dep.connect, mode=dep.zenoh_mode, listen=listen, max_message=self.settings.limits.max_message()))
        try:
            for name in self.names:
                cls = registry.load(name)
                svc = cls(self.settings, self.bus, cls.make_clock(self.settings))
                svc.inline = True
                (self.executors.setdefault(name, Executor()) if svc.blocking else self.executors["composed"]).add(svc)
                svc.start()
                self.services[name] = svc
        except BaseException:
            self.stop()
            raise
        for name, ex in self.executors.items():
            self._threads.append(threading.Thread(target=ex.run, name=f"zenav-{name}", daemon=True))
            self._threads[-1].start()
        return self

    def stop(self) -> None:
        """End the workers, close the services in the registry's stop order (each its on_stop), then the session."""
        for ex in self.executors.values():
            ex.stop()
        for th in self._threads:
            th.join(timeout=JOIN_TIMEOUT)
        self._threads = []
        for name in registry.stop_order(self.services):
            self.services.pop(name).close()
        if self.bus is not None:
            self.bus.close()
            self.bus = None

    def __enter__(self) -> ComposedStack:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()


def main(argv: Sequence[str] | None = None) -> int:
    """`python -m zenav.stack.composed --services odometry,localizer,navigator,motor [service options]`."""
    parser = argparse.ArgumentParser(prog="zenav-composed", description=__doc__.splitlines()[0], epilog=LOG_HELP)
    parser.add_argument("--services", required=True, help="comma-separated services to run in this process")
    deployment_args(parser)
    args = parser.parse_args(argv)
    names = [n.strip() for n in args.services.split(",") if n.strip()]
    unknown = set(names) - set(registry.ALL)
    if unknown:
        print(f"zenav-composed: unknown service(s): {', '.join(sorted(unknown))}", file=sys.stderr)
        return 2
    setup_logging()
    try:
        settings = settings_from_args(args)
        for name in names:
            cls = registry.load(name)
            if cls.config_type is not None:
                settings.section(name, cls.config_type)
    except ConfigError as e:
        print(f"zenav-composed: {e}", file=sys.stderr)
        return 2
    # Before Zenoh's threads start, so that they take it; a refusal shows in diag (`realtime_refused`).
    refused = realtime(settings.deployment.realtime, "zenav-composed") if any(n in CONTROL_LOOP for n in names) else None
    done = stop_on_signals()
    watch_parent(done.set)
    stack = ComposedStack(settings, names)
    try:
        stack.start()
    except Duplicate as e:
        print(f"zenav-composed: {e}", file=sys.stderr)
        return 3
    for name, svc in stack.services.items():
        if refused and name in CONTROL_LOOP:
            svc.count("realtime_refused")
    try:
        done.wait()
    finally:
        stack.stop()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
