"""The relay arm: the same stack with the four robot services replaced in place by relays.

A robot of its own (ROBOT) beside the measured one, on the same router and in the same
window: its own sim process (started as the stack's, with the same arguments) and, in
place of odometry, localizer, navigator and motor, one relay process each that decodes
its input with the service's input type and publishes an output of the service's output
type stamped with the input's t (its other fields zero: the sim's wheels stand still).
Composed, one relay process takes the encoder sample and publishes the four outputs in
chain order, as the composed process does. The stack's own observer process
(bench/latency.py) stamps the arm's chain as it stamps the stack's, so end to end of the
stack minus end to end of the arm is what the services' own work adds: their code, their
runtime's hand-off, their extra messages, all else (sim, hops, codec, router, host load)
alike.

Each relay is a process of its own (`relay`, run by bench/child.py; its service `composed`: the four in one).
"""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from zenav.bench import child
from zenav.bench.latency import OUTPUT, Observer, input_of
from zenav.common import codec, keys
from zenav.common import messages as m
from zenav.common.app import PEER_LISTEN
from zenav.common.bus import ZenohBus
from zenav.common.roles import OFF_CHAIN, ROBOT_SERVICES, chain
from zenav.stack.launcher import service_argv

ROBOT = "relays"  # the arm's robot id, apart from the stack's
COMPOSED = "composed"
READY = "ready"  # a relay's first line on stdout
STOP_WAIT = 10.0  # [s] for a process to end once told


def _odom(t: float) -> m.Odom:
    return m.Odom(t=t, x=0.0, y=0.0, theta=0.0, v=0.0, omega=0.0)


def _pose(t: float) -> m.Pose:
    return m.Pose(t=t, x=0.0, y=0.0, theta=0.0, v=0.0, omega=0.0)


def _cmd(t: float) -> m.CmdVel:
    return m.CmdVel(t=t, v=0.0, omega=0.0)


def _wheels(t: float) -> m.Wheels:
    return m.Wheels(t=t, left=0.0, right=0.0)


@dataclass(frozen=True)
class Hop:
    """What a robot service reads and publishes on the chain."""

    input: str
    type: type[m.Topic]
    output: str
    make: Callable[[float], m.Topic]  # its output for an input of time t


MAKE: dict[str, Callable[[float], m.Topic]] = {"odometry": _odom, "localizer": _pose, "navigator": _cmd, "motor": _wheels}
assert tuple(MAKE) == ROBOT_SERVICES


def hops(control_on: str) -> dict[str, Hop]:
    """Each robot service's hop, the chain's in its order, then those off it (the localizer's, with control on odom)."""
    order = (*chain(control_on), *OFF_CHAIN[control_on])
    return {s: Hop(input_of(s, control_on), keys.TOPICS[input_of(s, control_on)], OUTPUT[s], MAKE[s]) for s in order}


def outputs(service: str, data: bytes, control_on: str) -> list[tuple[str, bytes]]:
    """A relay's whole work on one message: (topic, payload) to publish, in order; BadInput if it does not decode."""
    table = hops(control_on)
    chosen = list(table.values()) if service == COMPOSED else [table[service]]
    t = codec.decode(data, chosen[0].type).t  # type: ignore[attr-defined]
    return [(h.output, codec.encode(h.make(t))) for h in chosen]


def relay(connect: str, service: str, mode: str, control_on: str, robot: str = ROBOT) -> None:
    """Stand in for `service` of `robot` until stdin closes."""
    bus = ZenohBus.open(connect, mode=mode, listen=PEER_LISTEN if mode == "peer" else None)
    table = hops(control_on)
    first = next(iter(table.values())) if service == COMPOSED else table[service]

    def on_msg(key: str, data: bytes) -> None:  # as the bare chain's relays: the floor's own price, on Zenoh's thread
        try:
            out = outputs(service, data, control_on)
        except codec.BadInput:
            return
        for topic, payload in out:
            bus.publish(keys.key(robot, topic), payload)

    bus.subscribe(keys.key(robot, first.input), on_msg)
    print(READY, flush=True)
    sys.stdin.read()  # the measuring process closes it to end the relay
    bus.close()


class Arm:
    """The arm's sim, its relays and its observer, on a running router: start() before the window, stages() at its end."""

    def __init__(
        self, connect: str, sim_args: Sequence[str], log: Path, control_on: str, mode: str = "client", composed: bool = False
    ) -> None:
        """`log`: the file the arm's sim writes its log to; `control_on`: the stack's [navigator] control_on."""
        sim = service_argv("sim", ["--connect", connect, "--robot", ROBOT, *sim_args, "--set", "sim.body_radius=0"])
        relays = (COMPOSED,) if composed else tuple(hops(control_on))
        self.argv = [sim] + [child.argv(relay, connect, s, mode, control_on) for s in relays]
        self.observer = Observer(connect, ROBOT, control_on, mode)
        self.log = log
        self.procs: list[subprocess.Popen[str]] = []

    def start(self) -> Arm:
        """Start the relays (each subscribed when this returns), the sim, the observer."""
        try:
            for argv in self.argv[1:]:
                p = subprocess.Popen(argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
                self.procs.append(p)
                assert p.stdout is not None
                if p.stdout.readline().strip() != READY:
                    raise RuntimeError("a relay of the relay arm did not start")
            self.log.parent.mkdir(parents=True, exist_ok=True)
            with open(self.log, "w") as log:
                self.procs.append(subprocess.Popen(self.argv[0], stdin=subprocess.DEVNULL, stdout=log, stderr=subprocess.STDOUT, text=True))
            self.observer.start()
        except BaseException:
            self.close()
            raise
        return self

    def stages(self) -> dict[str, list[float]]:
        """End the recording: per stage and end to end [ms], as the stack's observer gives them."""
        return self.observer.stages()

    def close(self) -> None:
        """Stop everything it started (idempotent)."""
        self.observer.close()
        for p in self.procs:
            if p.stdin is not None:
                p.stdin.close()  # a relay ends
            else:
                p.terminate()  # the sim ends on SIGTERM
        for p in self.procs:
            try:
                p.wait(timeout=STOP_WAIT)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
            if p.stdout is not None:
                p.stdout.close()
        self.procs = []
