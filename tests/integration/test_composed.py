"""Several services in one process: direct local delivery plus one shared Zenoh session."""

from __future__ import annotations

import os
import threading

import pytest

from zenav.common import codec, keys
from zenav.common import messages as m
from zenav.common.bus import ZenohBus
from zenav.common.config import Settings
from zenav.stack.composed import ComposedStack, LocalBus

WAIT = 10.0  # [s] for anything to arrive


class Inbox:
    """Collects (key, payload) pairs; `wait(n)` until n have come."""

    def __init__(self) -> None:
        self.got: list[tuple[str, bytes]] = []
        self._cond = threading.Condition()

    def __call__(self, key: str, data: bytes) -> None:
        with self._cond:
            self.got.append((key, data))
            self._cond.notify_all()

    def wait(self, n: int) -> bool:
        with self._cond:
            return self._cond.wait_for(lambda: len(self.got) >= n, timeout=WAIT)


@pytest.fixture
def pair(router):
    """A LocalBus on its own session, and a plain ZenohBus standing for the rest of the stack."""
    local, remote = LocalBus(ZenohBus.open(router)), ZenohBus.open(router)
    yield local, remote
    local.close()
    remote.close()


def test_a_local_publication_reaches_local_and_remote_subscribers_exactly_once(pair):
    local, remote = pair
    key = keys.key("r1", "odom")
    end = keys.key("r1", "end")
    here, there, marker = Inbox(), Inbox(), Inbox()
    local.subscribe(key, here)
    remote.subscribe(key, there)
    remote.subscribe(end, marker)
    local.subscribe(end, lambda k, d: None)
    # The remote subscribers, and a new publisher's first message, may take a moment: send on both keys until each
    # has come through once (a first message lost here took 10 s to retry in 1 of 6 runs).
    for _ in range(3):
        local.publish(key, b"probe")
        local.publish(end, b"")
        if there.wait(1) and marker.wait(1):
            break
    here.got.clear()
    there.got.clear()
    marker.got.clear()
    for i in range(20):
        local.publish(key, codec.encode(i))
    local.publish(end, b"")
    assert marker.wait(1) and there.wait(20)
    assert [codec.decode(d, int) for _, d in here.got] == list(range(20))  # direct, in order, once each
    assert [codec.decode(d, int) for _, d in there.got] == list(range(20))


def test_a_remote_publication_reaches_a_local_subscriber_once(pair):
    local, remote = pair
    key = keys.key("r1", "pose")
    here = Inbox()
    local.subscribe(key, here)
    for _ in range(20):
        remote.publish(key, b"probe")
        if here.wait(1):
            break
    n = len(here.got)
    remote.publish(key, b"x")
    assert here.wait(n + 1)
    assert here.got[-1] == (key, b"x") and len(here.got) == n + 1


def test_an_undeclared_local_subscription_gets_nothing_more(pair):
    local, _ = pair
    key = keys.key("r1", "cmd_vel")
    here = Inbox()
    handle = local.subscribe(key, here)
    local.publish(key, b"a")
    handle.undeclare()
    local.publish(key, b"b")
    assert here.got == [(key, b"a")]


def test_newest_keeps_the_last_sample_of_a_local_or_a_remote_publisher(pair):
    local, remote = pair
    key = keys.key("r1", "pose")
    newest = local.newest(key)
    local.publish(key, b"a")
    local.publish(key, b"b")
    assert newest.take() == b"b" and newest.take() is None  # from a service of the process: at once
    here = Inbox()  # on the same network subscriber, after newest: once it has a sample, newest has it
    local.subscribe(key, here)
    for _ in range(20):
        remote.publish(key, b"c")
        if here.wait(1):
            break
    assert newest.take() == b"c"  # from the network
    newest.undeclare()
    local.publish(key, b"d")
    assert newest.take() is None


def test_composed_services_each_keep_their_token_and_diag(router, client):
    settings = Settings.load(None, deployment={"connect": router, "clock": "wall"})
    names = ["motor", "odometry", "localizer"]
    with ComposedStack(settings, names) as stack:
        client.wait_alive(names, timeout=WAIT)
        diag = client.latest("diag/motor").wait(timeout=WAIT)
        assert diag.service == "motor"
        wheels = client.latest("motors/wheels")
        client.publish("cmd_vel", m.CmdVel(t=0.0, v=0.1, omega=0.0))
        assert wheels.wait(lambda w: w.left > 0.0, timeout=WAIT).right > 0.0
        odom = client.latest("odom")
        for i in range(20):  # the first sample is the odometry's baseline (and a new publisher's first may take a retry)
            client.publish("sensors/encoders", m.Encoders(t=0.01 * i, left=i, right=i))
            try:
                odom.wait(timeout=0.5)
                break
            except TimeoutError:
                continue
        # the odometry's pose reached the localizer beside it directly (its subscriptions take no local sample from Zenoh)
        localizer = client.latest("diag/localizer").wait(lambda d: d.counters["msgs_in"] >= 1, timeout=WAIT)
        assert localizer.service == "localizer" and set(stack.services) == set(names)


def test_a_driver_waiting_on_a_silent_board_holds_up_no_service_beside_it(router, client):
    """The driver blocks on its serial link, so composed it has a worker of its own: while it waits 3 s for a
    board that never answers, the motor in the same process keeps its timers."""
    board, line = os.openpty()  # a serial line with nothing on the other end
    try:
        driver = {"port": os.ttyname(line), "open_delay": 0.0, "reply_timeout": 3.0}
        settings = Settings.load(None, deployment={"connect": router, "clock": "wall"}, driver=driver)
        with ComposedStack(settings, ["driver", "motor"]) as stack:
            assert stack.services["driver"].blocking and not stack.services["motor"].blocking
            # diag comes once a second from each service's timers: the motor's second, while the driver still waits
            assert client.latest("diag/motor").wait(lambda d: d.uptime >= 1.0, timeout=2.5).service == "motor"
            waiting = client.latest("diag/driver").msg
            assert waiting is None or waiting.uptime < 1.0, waiting
            os.close(board)  # the line goes dead: the driver's wait ends now, not at its time-out
            board = -1
    finally:
        if board >= 0:
            os.close(board)
        os.close(line)


def test_a_token_is_seen_by_a_watcher_on_the_same_bus(pair):
    local, _ = pair
    seen: list[tuple[str, bool]] = []
    event = threading.Event()
    key = keys.alive("r1", "navigator")

    def watch(k: str, alive: bool) -> None:
        seen.append((k, alive))
        event.set()

    local.watch_tokens(key, watch)
    token = local.token(key)
    assert event.wait(WAIT) and seen[0] == (key, True)
    assert local.tokens(key) == [key]
    event.clear()
    token.undeclare()
    assert event.wait(WAIT) and seen[-1] == (key, False)


def test_services_on_one_key_share_a_network_subscriber_and_each_get_every_sample(pair):
    local, remote = pair
    key = keys.key("r1", "clock")
    first, second = Inbox(), Inbox()
    h1 = local.subscribe(key, first)
    local.subscribe(key, second)
    for _ in range(20):
        remote.publish(key, b"probe")
        if first.wait(1):
            break
    assert second.wait(len(first.got))
    h1.undeclare()
    n1, n2 = len(first.got), len(second.got)
    remote.publish(key, b"x")
    assert second.wait(n2 + 1) and second.got[-1] == (key, b"x")
    assert len(first.got) == n1  # undeclared: nothing more


@pytest.mark.parametrize(
    "control_on, order",
    [("odom", ["motor", "odometry", "navigator", "localizer"]), ("pose", ["motor", "odometry", "localizer", "navigator"])],
)
def test_composed_the_chain_s_services_subscribe_first(control_on, order):
    """In one process a sample reaches the subscribers in the order they came: the chain's before the localizer off it."""
    stack = ComposedStack(Settings.load(None, navigator={"control_on": control_on}), ["navigator", "localizer", "odometry", "motor"])
    assert stack.names == order
