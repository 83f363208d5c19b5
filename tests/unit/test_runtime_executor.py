"""Services composed in one process share one worker: runtime.Executor."""

import threading

from tests.support.echo import Echo
from tests.support.procs import niceness
from zenav.common import codec, keys
from zenav.common import messages as m
from zenav.common.bus import MemoryBus
from zenav.common.clock import ManualClock
from zenav.common.config import Settings
from zenav.common.runtime import Executor, Service, publish, subscribe


class Forward(Service):
    """Encoders in, a command out (as the chain's first services would)."""

    name = "navigator"

    def __init__(self, *a):
        super().__init__(*a)
        self.threads: list[int] = []

    @subscribe("sensors/encoders")
    @publish("cmd_vel")
    def on_encoders(self, msg: m.Encoders) -> m.CmdVel:
        self.threads.append(threading.get_ident())
        return m.CmdVel(t=msg.t, v=0.1, omega=0.0)


def serve_one(executor: Executor, bus: MemoryBus, robot: str, done: threading.Event) -> threading.Thread:
    """Run the executor on a thread of its own until one encoder sample of `robot` has led to `done`; its thread, ended."""
    worker = threading.Thread(target=executor.run)
    worker.start()
    try:
        bus.publish(keys.key(robot, "sensors/encoders"), codec.encode(m.Encoders(t=0.5, left=1, right=2)))
        assert done.wait(5.0)
    finally:
        executor.stop()
        worker.join(5.0)
    assert not worker.is_alive()
    return worker


def test_a_message_passes_through_the_composed_services_on_the_executors_thread():
    bus, clock = MemoryBus(), ManualClock(1.0)
    executor = Executor()
    services = [Forward(Settings.load(None), bus, clock), Echo(Settings.load(None), bus, clock)]
    for svc in services:
        executor.add(svc)
        svc.start()
    wheels: list[tuple[int, m.Wheels]] = []
    arrived = threading.Event()

    def on_wheels(key: str, data: bytes) -> None:
        wheels.append((threading.get_ident(), codec.decode(data, m.Wheels)))
        arrived.set()

    bus.subscribe(keys.key("r1", "motors/wheels"), on_wheels)
    worker = serve_one(executor, bus, "r1", arrived)
    assert services[0].threads == [worker.ident] and [(ident, w.t, w.left) for ident, w in wheels] == [(worker.ident, 0.5, 0.1)]
    for svc in services:
        svc.close()


def test_an_executor_of_background_services_runs_at_a_lower_priority():
    """Services off the control loop's path (a camera vps) yield the cores; composed with any other, they do not."""

    def niceness_served(background: tuple[bool, ...]) -> list[int]:
        bus, clock, executor = MemoryBus(), ManualClock(1.0), Executor()
        services = [Forward(Settings.load(None, deployment={"robot": f"r{i}"}), bus, clock) for i in range(len(background))]
        seen, served = [], threading.Event()
        for svc, bg in zip(services, background):
            svc.background = bg
            executor.add(svc)
            svc.start()
        bus.subscribe(
            keys.key("r0", "cmd_vel"),
            lambda key, data: (seen.append(niceness()), served.set()),
        )
        serve_one(executor, bus, "r0", served)
        for svc in services:
            svc.close()
        return seen

    mine = niceness()
    assert niceness_served((True,)) == [min(mine + 10, 19)]
    assert niceness_served((True, False)) == [mine]
