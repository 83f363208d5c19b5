"""Running one service as a process: args and env -> settings -> session -> run."""

from __future__ import annotations

import argparse
import logging
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

import zenoh

if sys.version_info >= (3, 11):
    import tomllib
else:  # Python 3.10
    import tomli as tomllib
from zenav.common.bus import ZenohBus
from zenav.common.config import ConfigError, Deployment, Settings
from zenav.common.roles import CONTROL_LOOP
from zenav.common.runtime import Duplicate, Service

PEER_LISTEN = "tcp/127.0.0.1:0"  # a peer service's own endpoint: loopback, any free port
LOG_LEVELS = ("DEBUG", "INFO", "WARNING", "ERROR")  # what ZENAV_LOG takes
CONNECT_STEP = 2.0  # [s] a service waiting for its router says so this often
LOG_HELP = "env ZENAV_LOG: log level of the service processes (DEBUG, INFO, WARNING, ERROR; default INFO)"


def realtime(priority: int, who: str) -> str | None:
    """Put this thread, and every thread it starts from now on (Zenoh's, when a session opens next), at
    SCHED_FIFO `priority`; 0 leaves the host's scheduling. The warning logged if the host refuses (the process
    then runs on at normal priority), else None."""
    if priority <= 0:
        return None
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
    except OSError as e:
        why = (
            f"{who}: real-time priority {priority} refused ({e.strerror}): running at normal priority "
            "(it needs CAP_SYS_NICE or an rtprio limit: docs/running.md)"
        )
        logging.getLogger("zenav").warning(why)
        return why
    logging.getLogger("zenav").info("%s: real-time priority %d (SCHED_FIFO)", who, priority)
    return None


def normal_priority() -> None:
    """Put this thread back at the host's normal scheduling (threads started meanwhile keep theirs)."""
    os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))


def connection_args(parser: argparse.ArgumentParser) -> None:
    """The options of every command that talks to a robot: which robot, through which router (each also from env)."""
    parser.add_argument("--robot", default=os.environ.get("ZENAV_ROBOT"), help="robot id (env ZENAV_ROBOT; default r1)")
    parser.add_argument(
        "--connect", default=os.environ.get("ZENOH_CONNECT"), help="router endpoint(s) (env ZENOH_CONNECT; default tcp/127.0.0.1:7447)"
    )
    parser.add_argument(
        "--zenoh-mode",
        choices=("client", "peer"),
        default=os.environ.get("ZENOH_MODE"),
        help="client: every message through the router; peer: services on this host also link directly (env ZENOH_MODE; default client)",
    )


def deployment_args(parser: argparse.ArgumentParser) -> None:
    """The options of a process that runs services (a service, `zenav up`): the connection, then the configuration."""
    connection_args(parser)
    parser.add_argument("--config", default=os.environ.get("ZENAV_CONFIG"), help="config file (env ZENAV_CONFIG)")
    parser.add_argument("--scenario", default=os.environ.get("ZENAV_SCENARIO"), help="scenario preset (env ZENAV_SCENARIO)")
    parser.add_argument("--seed", type=int, default=os.environ.get("ZENAV_SEED"), help="random seed (env ZENAV_SEED)")
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="SECTION.KEY=VALUE",
        help="override one config key, value in TOML syntax (repeatable): --set sim.rtf=5",
    )


def parse_sets(items: Sequence[str]) -> dict[str, dict[str, Any]]:
    """`["sim.rtf=5", 'odometry.integrator="arc"']` -> {"sim": {"rtf": 5}, ...}; ConfigError if malformed."""
    out: dict[str, dict[str, Any]] = {}
    for item in items:
        name, sep, value = item.partition("=")
        section, dot, key = name.strip().partition(".")
        if not (sep and dot and section and key):
            raise ConfigError(f"--set {item!r}: expected SECTION.KEY=VALUE")
        try:
            parsed = tomllib.loads(f"v = {value.strip()}")["v"]
        except tomllib.TOMLDecodeError:
            parsed = value.strip()  # bare words are strings: --set odometry.integrator=arc
        out.setdefault(section, {})[key] = parsed
    return out


def settings_from_args(args: argparse.Namespace, **overrides: dict[str, Any]) -> Settings:
    """Settings from the config file, with the deployment options applied."""
    dep = {"robot": args.robot, "connect": args.connect, "zenoh_mode": args.zenoh_mode, "scenario": args.scenario, "seed": args.seed}
    dep = {k: (int(v) if k == "seed" and v is not None else v) for k, v in dep.items()}
    sets = parse_sets(args.set)
    sets["deployment"] = {**sets.get("deployment", {}), **{k: v for k, v in dep.items() if v is not None}}
    for name, values in overrides.items():
        sets[name] = {**sets.get(name, {}), **values}
    return Settings.load(args.config, **sets)


def setup_logging(level: str = "INFO") -> None:
    """Log to stderr at $ZENAV_LOG (default `level`); ConfigError if it names no level."""
    name = os.environ.get("ZENAV_LOG", level).strip().upper()
    if name not in LOG_LEVELS:
        raise ConfigError(f"ZENAV_LOG={name!r}: expected one of {', '.join(LOG_LEVELS)}")
    logging.basicConfig(level=name, format="%(asctime)s %(name)s %(levelname)s %(message)s", stream=sys.stderr)


class _Signals:
    """The process's one way from a signal handler to the event of the newest `stop_on_signals`.

    The handler takes no lock: it writes a byte to a pipe, and a thread of its own sets the
    event. A handler runs on the main thread between two of its steps, maybe while that
    thread holds the lock that setting the event (or queueing a stop) takes, as it does
    inside `Event.wait`: taken there, the lock would never be released, and the process
    would never stop."""

    def __init__(self) -> None:
        self.event = threading.Event()
        self._wake: int | None = None  # the pipe's write end, once the relay thread runs

    def handler(self, signum: int, frame: object) -> None:
        if self._wake is None:
            return
        try:
            os.write(self._wake, b"\0")
        except BlockingIOError:  # the pipe is full: the stop is already on its way
            pass

    def watch(self, signals: Sequence[signal.Signals]) -> threading.Event:
        self.event = threading.Event()
        if self._wake is None:
            read_end, self._wake = os.pipe()
            os.set_blocking(self._wake, False)
            threading.Thread(target=self._relay, args=(read_end,), name="zenav-signals", daemon=True).start()
        for sig in signals:
            signal.signal(sig, self.handler)
        return self.event

    def _relay(self, read_end: int) -> None:
        while os.read(read_end, 1):
            self.event.set()


_SIGNALS = _Signals()


def stop_on_signals(signals: Sequence[signal.Signals] = (signal.SIGINT, signal.SIGTERM)) -> threading.Event:
    """An event set by SIGINT or SIGTERM (Ctrl-C, `docker stop`, `zenav up`), or the signals given
    (main thread only; the newest call's event is the one set)."""
    return _SIGNALS.watch(signals)


def watch_parent(stop: Callable[[], None]) -> None:
    """Under `zenav up` (ZENAV_PARENT_PID set): stop when the launcher is gone."""
    parent = os.environ.get("ZENAV_PARENT_PID")
    if not parent:
        return

    def loop() -> None:
        while os.getppid() == int(parent):
            time.sleep(1.0)  # polling the parent, not synchronising anything
        logging.getLogger("zenav").warning("launcher %s gone: stopping", parent)
        stop()

    threading.Thread(target=loop, name="zenav-parent-watch", daemon=True).start()


def wait_for_router(dep: Deployment, done: threading.Event, step: float = CONNECT_STEP, max_message: int | None = None) -> ZenohBus | None:
    """A session to the deployment's router, waiting for it (a log line each `step` [s]
    without one) until `done` is set (then None): a service under a supervisor may start
    before its router, and Ctrl-C still stops it within `step`. `max_message` [bytes]: larger messages are dropped by Zenoh."""
    listen = PEER_LISTEN if dep.zenoh_mode == "peer" else None
    tries = 0
    while not done.is_set():
        try:
            return ZenohBus.open(dep.connect, mode=dep.zenoh_mode, listen=listen, connect_timeout=step, max_message=max_message)
        except zenoh.ZError:
            tries += 1
            logging.getLogger("zenav").warning("no router at %s after %.0f s: still trying", dep.connect, tries * step)
    return None


def main(service_cls: type[Service], argv: Sequence[str] | None = None) -> int:
    """Run `service_cls` until SIGINT or SIGTERM; exit 2 on bad config (checked before
    connecting), 3 if it already runs for this robot; waits for its router as long as it takes."""
    parser = argparse.ArgumentParser(prog=f"zenav-{service_cls.name}", description=service_cls.__doc__, epilog=LOG_HELP)
    deployment_args(parser)
    args = parser.parse_args(argv)
    try:
        setup_logging()
        settings = settings_from_args(args)
        if service_cls.config_type is not None:
            settings.section(service_cls.name, service_cls.config_type)
        svc_clock = service_cls.make_clock(settings)
    except ConfigError as e:
        print(f"zenav-{service_cls.name}: {e}", file=sys.stderr)
        return 2
    # Before Zenoh's threads start, so that they take it; a refusal shows in diag (`realtime_refused`).
    refused = realtime(settings.deployment.realtime, f"zenav-{service_cls.name}") if service_cls.name in CONTROL_LOOP else None
    done = stop_on_signals()
    bus = wait_for_router(settings.deployment, done, max_message=settings.limits.max_message())
    if bus is None:
        return 0
    try:
        svc = service_cls(settings, bus, svc_clock)  # checks that need more than one key (e.g. the navigator's gains)
    except ConfigError as e:
        print(f"zenav-{service_cls.name}: {e}", file=sys.stderr)
        bus.close()
        return 2

    svc.inline = True
    if refused:
        svc.count("realtime_refused")

    # Stopped by a signal (at once if one came while the service was being built), or by the launcher's going.
    watch_parent(done.set)

    def stop_when_done() -> None:
        done.wait()
        svc.stop()

    threading.Thread(target=stop_when_done, name="zenav-stop", daemon=True).start()
    try:
        svc.start()
        svc.run()
    except Duplicate as e:
        print(f"zenav-{service_cls.name}: {e}", file=sys.stderr)
        return 3
    finally:
        svc.close()
        bus.close()
    return 0
