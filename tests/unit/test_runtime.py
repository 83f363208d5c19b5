"""The service runtime on the in-memory bus with a manual clock."""
import math

import msgpack
import pytest

from zenav.common import codec, keys
from zenav.common import messages as m
from zenav.common.bus import MemoryBus
from zenav.common.clock import ManualClock, SimClock
from zenav.common.config import Settings
from zenav.common.runtime import QueryError, Service, on_liveliness, publish, query, subscribe, timer


class Echo(Service):
    name = "motor"

    def __init__(self, *a):
        super().__init__(*a)
        self.ticks = []
        self.held = None

    @subscribe("cmd_vel")
    @publish("motors/wheels")
    def on_cmd(self, msg: m.CmdVel) -> m.Wheels:
        if msg.v > 100:
            raise RuntimeError("boom")
        return m.Wheels(t=msg.t, left=msg.v, right=msg.omega)

    @timer(0.5)
    def tick(self, now: float) -> None:
        self.ticks.append(now)

    @on_liveliness("navigator")
    @publish("motors/wheels")
    def navigator_presence(self, alive: bool):
        self.navigator_alive = alive
        return None if alive else m.Wheels(t=0.0, left=0.0, right=0.0)

    @query("localizer/set_pose")
    def set_pose(self, req: m.SetPose, q):
        if req.x == 13.0:
            raise QueryError("unavailable", "unlucky")
        if req.x == 7.0:
            self.held = q  # answered later
            return None
        return m.PoseStamped(t=0.0, x=req.x or 0.0, y=req.y or 0.0, theta=0.0)


@pytest.fixture
def svc():
    bus, clock = MemoryBus(), ManualClock()
    s = Echo(Settings.load(None), bus, clock)
    s.start()
    yield s, bus, clock
    s.close()


def published(bus, suffix):
    typ = keys.TOPICS[suffix]
    return [codec.decode(d, typ) for k, d in bus.published if k == keys.key("r1", suffix)]


def test_handler_output_is_published(svc):
    s, bus, _ = svc
    bus.publish("zenav/r1/cmd_vel", codec.encode(m.CmdVel(t=1.0, v=0.2, omega=0.1)))
    assert published(bus, "motors/wheels") == []  # callbacks only enqueue
    s.drain()
    assert published(bus, "motors/wheels") == [m.Wheels(t=1.0, left=0.2, right=0.1)]
    assert s.counters.values["msgs_in"] == 1 and s.counters.values["msgs_out"] == 1


@pytest.mark.parametrize(
    "payload",
    [b"\xc1", b"", msgpack.packb([1, 2]), msgpack.packb({"t": 1.0, "v": "fast", "omega": 0.0}),
     msgpack.packb({"t": 1.0, "v": math.nan, "omega": 0.0}), msgpack.packb({"t": 1.0, "v": 1e300, "omega": 0.0}),
     msgpack.packb({"t": 1.0, "omega": 0.0})],
)
def test_bad_input_is_counted_and_dropped(svc, payload):
    s, bus, _ = svc
    bus.publish("zenav/r1/cmd_vel", payload)
    bus.publish("zenav/r1/cmd_vel", codec.encode(m.CmdVel(t=2.0, v=0.1, omega=0.0)))
    s.drain()
    assert s.counters.values["bad_input"] == 1
    assert [w.t for w in published(bus, "motors/wheels")] == [2.0]  # still serving


def test_unknown_topic_keys_are_ignored(svc):
    s, bus, _ = svc
    bus.publish("zenav/r1/cmd_vel", msgpack.packb({"t": 1.0, "v": 0.1, "omega": 0.0, "future_field": [1]}))
    s.drain()
    assert len(published(bus, "motors/wheels")) == 1 and s.counters.values["bad_input"] == 0


def test_handler_exception_is_counted_and_service_continues(svc):
    s, bus, _ = svc
    bus.publish("zenav/r1/cmd_vel", codec.encode(m.CmdVel(t=1.0, v=200.0, omega=0.0)))
    bus.publish("zenav/r1/cmd_vel", codec.encode(m.CmdVel(t=2.0, v=0.1, omega=0.0)))
    s.drain()
    assert s.counters.values["errors"] == 1
    assert [w.t for w in published(bus, "motors/wheels")] == [2.0]


def test_timers_follow_the_clock(svc):
    s, bus, clock = svc
    s.drain()  # first run schedules at now + period
    clock.advance(0.4)
    s.drain()
    assert s.ticks == []
    clock.advance(0.1)
    s.drain()
    assert s.ticks == [0.5]
    clock.advance(3.0)  # fell behind: one run, then back on schedule
    s.drain()
    assert s.ticks == [0.5, 3.5] and s.counters.values["timer_overruns"] >= 1


def test_diag_every_second_with_counters_and_rates(svc):
    s, bus, clock = svc
    s.drain()
    for i in range(10):
        bus.publish("zenav/r1/cmd_vel", codec.encode(m.CmdVel(t=i * 0.1, v=0.1, omega=0.0)))
        clock.advance(0.1)
        s.drain()
    clock.advance(0.01)  # ten steps of 0.1 fall just short of 1.0 in floating point
    s.drain()
    diags = published(bus, "diag/motor")
    assert len(diags) == 1
    d = diags[0]
    assert d.service == "motor" and d.status == "ok"
    assert d.counters["msgs_in"] == 10 and d.counters["bad_input"] == 0
    assert d.rates["cmd_vel"] == pytest.approx(10.0)


def test_liveliness_token_while_up():
    bus = MemoryBus()
    s = Echo(Settings.load(None, deployment={"robot": "bot_7"}), bus, ManualClock())
    assert bus.alive() == []
    s.start()
    assert bus.alive() == ["zenav/bot_7/alive/motor"]
    s.close()
    assert bus.alive() == []


def test_query_payload_and_selector_parameters(svc):
    s, bus, _ = svc
    q1 = bus.query("zenav/r1/localizer/set_pose", codec.encode({"x": 1.0, "y": 2.0}))
    q2 = bus.query("zenav/r1/localizer/set_pose", params={"x": "3", "y": "0.5"})
    s.drain()
    assert q1.replies == [(True, codec.encode(m.PoseStamped(t=0.0, x=1.0, y=2.0, theta=0.0)))]
    assert codec.decode(q2.replies[0][1], m.PoseStamped).x == 3.0
    assert q1.finished and q2.finished


@pytest.mark.parametrize(
    "payload, code, words",
    [
        ({"x": 1.0, "tolerence": 1}, "invalid_argument", "tolerence"),
        ({"x": "one"}, "invalid_argument", "$.x"),
        ({"x": math.inf}, "invalid_argument", "$.x"),
        ({"x": 13.0}, "unavailable", "unlucky"),
    ],
)
def test_query_errors_are_replied(svc, payload, code, words):
    s, bus, _ = svc
    q = bus.query("zenav/r1/localizer/set_pose", codec.encode(payload))
    s.drain()
    [(ok, data)] = q.replies
    err = codec.decode(data, m.ErrorReply)
    assert not ok and err.error == code and words in err.message


def test_deferred_reply(svc):
    s, bus, _ = svc
    q = bus.query("zenav/r1/localizer/set_pose", codec.encode({"x": 7.0}))
    s.drain()
    assert q.replies == [] and s.held is q


def test_sim_clock_service_follows_clock_topic():
    bus = MemoryBus()
    clock = SimClock()
    s = Echo(Settings.load(None), bus, clock)
    s.start()
    assert not clock.ready
    bus.publish("zenav/r1/clock", codec.encode(m.Clock(t=12.0, rtf=1.0)))
    s.drain()
    assert clock.ready and 12.0 <= clock.now() <= 12.06
    s.close()


def test_liveliness_handler_runs_in_the_worker(svc):
    s, bus, _ = svc
    tok = bus.token("zenav/r1/alive/navigator")
    bus.token("zenav/r1/alive/sim")  # another service: not watched
    assert not hasattr(s, "navigator_alive")  # callbacks only enqueue
    s.drain()
    assert s.navigator_alive is True and published(bus, "motors/wheels") == []
    tok.undeclare()
    s.drain()
    assert s.navigator_alive is False
    assert published(bus, "motors/wheels") == [m.Wheels(t=0.0, left=0.0, right=0.0)]


def test_clock_restart_reschedules_timers_and_calls_the_hook():
    bus, clock = MemoryBus(), SimClock()
    s = Echo(Settings.load(None), bus, clock)
    resets = []
    s.on_clock_reset = lambda: resets.append(clock.now())
    s.start()
    bus.publish("zenav/r1/clock", codec.encode(m.Clock(t=500.0, wall=0.0)))
    s.drain()
    bus.publish("zenav/r1/clock", codec.encode(m.Clock(t=0.01, wall=0.0)))
    s.drain()
    assert len(resets) == 1 and resets[0] < 1.0
    assert s.counters.values["clock_resets"] == 1
    assert all(tm.due is not None and tm.due < 2.0 for tm in s._timers)  # not waiting for t = 500
    s.close()


def test_a_message_from_the_future_is_dropped_and_later_ones_still_served():
    bus, clock = MemoryBus(), SimClock()
    s = Echo(Settings.load(None), bus, clock)
    s.start()
    cmd = "zenav/r1/cmd_vel"
    bus.publish(cmd, codec.encode(m.CmdVel(t=1e6, v=0.1, omega=0.0)))  # before any tick: nothing to judge by
    bus.publish("zenav/r1/clock", codec.encode(m.Clock(t=10.0, rtf=1.0)))
    bus.publish(cmd, codec.encode(m.CmdVel(t=10.5, v=0.1, omega=0.0)))  # within the limit
    bus.publish(cmd, codec.encode(m.CmdVel(t=1010.0, v=0.1, omega=0.0)))  # a broken stamp
    bus.publish(cmd, codec.encode(m.CmdVel(t=10.02, v=0.1, omega=0.0)))
    s.drain()
    assert [w.t for w in published(bus, "motors/wheels")] == [1e6, 10.5, 10.02]
    assert s.counters.values["dropped_future"] == 1
    s.close()
