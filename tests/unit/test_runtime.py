"""The service runtime on the in-memory bus with a manual clock."""

import math
import time

import msgpack
import pytest

from tests.support.echo import Echo
from zenav.common import codec, keys, runtime
from zenav.common import messages as m
from zenav.common.bus import MemoryBus
from zenav.common.clock import ManualClock, SimClock
from zenav.common.config import Settings
from zenav.common.runtime import Service, subscribe


def started(clock):
    """A started Echo on a MemoryBus and `clock`: yields (service, bus, clock), then closes it."""
    bus = MemoryBus()
    s = Echo(Settings.load(None), bus, clock)
    s.start()
    yield s, bus, clock
    s.close()


@pytest.fixture
def svc():
    yield from started(ManualClock())


@pytest.fixture
def sim_svc():
    """Echo on a SimClock: its time comes from the clock topic."""
    yield from started(SimClock())


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
    [
        b"\xc1",
        b"",
        msgpack.packb([1, 2]),
        msgpack.packb({"t": 1.0, "v": "fast", "omega": 0.0}),
        msgpack.packb({"t": 1.0, "v": math.nan, "omega": 0.0}),
        msgpack.packb({"t": 1.0, "v": 1e300, "omega": 0.0}),
        msgpack.packb({"t": 1.0, "omega": 0.0}),
    ],
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


@pytest.mark.parametrize("inline", [False, True], ids=["worker", "inline"])
def test_an_output_that_fails_to_go_out_is_counted_and_the_next_input_is_served(svc, monkeypatch, inline):
    s, bus, _ = svc
    s.inline = inline  # served on the publishing thread, as on a Zenoh thread: nothing may be raised into it
    publish, failed = bus.publish, []

    def failing_once(key, data):
        if key.endswith("/motors/wheels") and not failed:
            failed.append(key)
            raise RuntimeError("session closing")  # as a Zenoh publisher's put can
        publish(key, data)

    monkeypatch.setattr(bus, "publish", failing_once)
    bus.publish("zenav/r1/cmd_vel", codec.encode(m.CmdVel(t=1.0, v=0.1, omega=0.0)))
    bus.publish("zenav/r1/cmd_vel", codec.encode(m.CmdVel(t=2.0, v=0.1, omega=0.0)))
    s.drain()
    assert failed and s.counters.values["errors"] == 1
    assert [w.t for w in published(bus, "motors/wheels")] == [2.0]


def test_a_topic_followed_newest_keeps_its_last_sample_unserved_until_read(svc):
    s, bus, _ = svc
    newest = s.newest("odom")

    def odom(t):
        bus.publish(keys.key("r1", "odom"), codec.encode(m.Odom(t=t, x=0.0, y=0.0, theta=0.0, v=0.0, omega=0.0)))

    for i in range(3):
        odom(float(i))
    assert s.counters.values["msgs_in"] == 0  # no handler, no input served
    assert newest.msg.t == 2.0
    bus.publish(keys.key("r1", "odom"), b"\xc1")  # a payload that does not decode: counted, the one before kept
    assert newest.msg.t == 2.0 and s.counters.values["bad_input"] == 1
    newest.forget()
    assert newest.msg is None  # nothing newer came
    s.close()
    odom(3.0)
    assert newest.msg is None  # undeclared with the service


def test_a_topic_followed_newest_gives_none_from_the_future(sim_svc):
    s, bus, _ = sim_svc
    newest = s.newest("pose")

    def pose(t):
        bus.publish(keys.key("r1", "pose"), codec.encode(m.Pose(t=t, x=0.0, y=0.0, theta=0.0, v=0.0, omega=0.0)))

    tick(bus, s, 10.0)
    tick(bus, s, 10.01)
    assert newest.msg is None  # nothing came
    pose(10.0)
    assert newest.msg.t == 10.0
    pose(10.91)  # 0.9 s ahead: counted, the one before kept
    assert newest.msg.t == 10.0 and s.counters.values["dropped_future"] == 1
    pose(10.02)
    assert newest.msg.t == 10.02 and s.counters.values["msgs_in"] == 0


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


def test_diag_reports_the_process_cpu_since_the_previous_one(svc):
    s, _, clock = svc
    s.diag(clock.now())
    start = time.process_time()
    for _ in range(10_000_000):  # at most a few seconds: until 20 ms of CPU are spent
        if time.process_time() - start > 0.02:
            break
    d = s.diag(clock.now())
    assert d.cpu is not None and 0.0 < d.cpu


class Slow(Service):
    """A motor whose handler takes at least `work` seconds of wall time (a bounded busy loop)."""

    name = "motor"
    work = 0.002

    @subscribe("cmd_vel")
    def on_cmd(self, msg: m.CmdVel) -> None:
        end = time.perf_counter() + self.work
        for _ in range(10_000_000):  # bounded: a few seconds at most on any host
            if time.perf_counter() >= end:
                break


def test_diag_says_how_long_serving_one_message_of_each_input_took():
    bus, clock = MemoryBus(), ManualClock()
    s = Slow(Settings.load(None), bus, clock)
    s.start()
    try:
        s.drain()
        for i in range(3):
            bus.publish("zenav/r1/cmd_vel", codec.encode(m.CmdVel(t=i * 0.1, v=0.1, omega=0.0)))
        bus.publish("zenav/r1/cmd_vel", b"\xc1")  # bad input: dropped before any handler, not timed
        s.drain()
        d = s.diag(clock.now())
        assert set(d.serve) == {"cmd_vel"} and Slow.work * 1e6 <= d.serve["cmd_vel"] < 1e6
        assert s.diag(clock.now()).serve == {}  # each diag covers what came since the one before
    finally:
        s.close()


def test_liveliness_token_while_up():
    bus = MemoryBus()
    s = Echo(Settings.load(None, deployment={"robot": "bot_7"}), bus, ManualClock())
    assert bus.alive() == []
    s.start()
    assert bus.alive() == ["zenav/bot_7/alive/motor", f"zenav/bot_7/instance/motor/{s.instance}"]
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


def test_sim_clock_service_follows_clock_topic(sim_svc):
    s, bus, clock = sim_svc
    assert not clock.ready
    bus.publish("zenav/r1/clock", codec.encode(m.Clock(t=12.0, rtf=1.0)))
    s.drain()
    assert clock.ready and 12.0 <= clock.now() <= 12.06


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
    diags = len(published(bus, "diag/motor"))
    bus.publish("zenav/r1/clock", codec.encode(m.Clock(t=0.01, wall=0.0, instance="sim-2")))  # a new sim instance
    s.drain()
    assert len(resets) == 1 and resets[0] < 1.0
    assert s.counters.values["clock_resets"] == 1
    restarted = published(bus, "diag/motor")[diags:]  # at once: the service is heard from again
    assert len(restarted) == 1 and restarted[0].t < 1.0 and restarted[0].counters["clock_resets"] == 1
    assert all(tm.due is not None and tm.due < 2.0 for tm in s._timers.timers)  # not waiting for t = 500
    s.close()


def test_a_message_from_the_future_is_dropped_and_later_ones_still_served(sim_svc):
    s, bus, clock = sim_svc
    cmd = "zenav/r1/cmd_vel"
    bus.publish(cmd, codec.encode(m.CmdVel(t=1e6, v=0.1, omega=0.0)))  # before any tick: nothing to judge by
    bus.publish("zenav/r1/clock", codec.encode(m.Clock(t=10.0, rtf=1.0)))
    bus.publish(cmd, codec.encode(m.CmdVel(t=10.5, v=0.1, omega=0.0)))  # within the limit
    bus.publish(cmd, codec.encode(m.CmdVel(t=1010.0, v=0.1, omega=0.0)))  # a broken stamp
    bus.publish(cmd, codec.encode(m.CmdVel(t=10.02, v=0.1, omega=0.0)))
    s.drain()
    assert [w.t for w in published(bus, "motors/wheels")] == [1e6, 10.5, 10.02]
    assert s.counters.values["dropped_future"] == 1


def test_a_watch_runs_its_handler_in_the_worker(svc):
    s, bus, _ = svc
    seen = []
    handle = s.watch("zenav/r1/lease/me", seen.append)
    tok = bus.token("zenav/r1/lease/me")
    assert seen == []  # callbacks only enqueue
    s.drain()
    tok.undeclare()
    s.drain()
    assert seen == [True, False]
    handle.undeclare()
    bus.token("zenav/r1/lease/me")
    s.drain()
    assert seen == [True, False]


def tick(bus, s, t, rtf=1.0, instance=""):
    bus.publish("zenav/r1/clock", codec.encode(m.Clock(t=t, rtf=rtf, instance=instance)))
    s.drain()


def test_implausible_clock_ticks_are_refused_and_counted(sim_svc):
    s, bus, clock = sim_svc
    tick(bus, s, 10.0)
    tick(bus, s, 10.01)
    tick(bus, s, 10.02, rtf=200.0)  # an absurd rtf
    tick(bus, s, 20.0)  # ten seconds ahead of a tick just taken
    assert clock.now() < 10.1 and s.counters.values["clock_refused"] == 2
    # Every tick taken is counted, refused or not, and none as a service's input.
    assert s.counters.values["clock_ticks"] == 4 and s.counters.values["msgs_in"] == 0
    tick(bus, s, 10.03)
    assert 10.03 <= clock.now() < 10.1
    tick(bus, s, 2.0)  # far back, from the same sim: refused
    assert s.counters.values["clock_refused"] == 3 and clock.now() >= 10.03
    tick(bus, s, 2.0, instance="sim-2")  # a new sim: it restarted
    assert s.counters.values["clock_resets"] == 1 and clock.now() < 2.1


def test_a_run_of_agreeing_refused_ticks_is_a_new_timeline(sim_svc):
    s, bus, clock = sim_svc
    tick(bus, s, 1.0)
    for i in range(25):
        tick(bus, s, 100.0 + 0.01 * i, rtf=5.0)
        if clock.now() >= 100.0:
            break
    assert clock.now() >= 100.0 and s.counters.values["clock_refused"] == 19 and s.counters.values["clock_resets"] == 1


def test_a_sample_stamped_ahead_of_the_sim_clock_by_more_than_a_tick_is_dropped(sim_svc):
    s, bus, clock = sim_svc
    cmd = "zenav/r1/cmd_vel"
    tick(bus, s, 10.0)
    tick(bus, s, 10.01)
    bus.publish(cmd, codec.encode(m.CmdVel(t=10.02, v=0.1, omega=0.0)))  # the next tick's sample: fine
    bus.publish(cmd, codec.encode(m.CmdVel(t=10.91, v=0.1, omega=0.0)))  # 0.9 s ahead
    bus.publish(cmd, codec.encode(m.CmdVel(t=10.02, v=0.1, omega=0.0)))
    s.drain()
    assert [w.t for w in published(bus, "motors/wheels")] == [10.02, 10.02]
    assert s.counters.values["dropped_future"] == 1


def test_an_input_stamped_on_another_stacks_clock_is_not_held_to_this_ones_horizon(sim_svc):
    s, bus, clock = sim_svc
    bodies: list[float] = []
    s.subscribe("sim/body", m.Body, lambda msg: bodies.append(msg.t), other_clock=True)
    tick(bus, s, 10.0)
    body = "zenav/field/sim/body"  # a field topic, whichever robot the service is
    bus.publish(body, codec.encode(m.Body(t=500.0, robot="r2", x=0.0, y=0.0, radius=0.1)))  # a sim far ahead of this one
    bus.publish("zenav/r1/cmd_vel", codec.encode(m.CmdVel(t=500.0, v=0.1, omega=0.0)))  # on this clock: dropped
    s.drain()
    assert bodies == [500.0] and s.counters.values["dropped_future"] == 1


def test_a_call_runs_once_when_the_clock_reaches_its_time(svc):
    s, bus, clock = svc
    s.drain()
    calls = []

    @runtime.publish("motors/wheels")
    def later(now):
        calls.append(("later", now))
        return m.Wheels(t=now, left=1.0, right=1.0)

    s.call_at(0.3, later)
    s.call_at(0.2, lambda now: calls.append(("sooner", now)))  # in the order of their times
    clock.t = 0.19
    s.drain()
    assert calls == []
    clock.t = 0.3
    s.drain()
    assert calls == [("sooner", 0.3), ("later", 0.3)]
    assert [w.t for w in published(bus, "motors/wheels")] == [0.3]
    clock.t = 5.0
    s.drain()
    assert len(calls) == 2  # once


def test_a_call_sooner_than_every_timer_wakes_the_worker(svc):
    s, _, clock = svc
    s.drain()  # the timers are due 0.5 s and 1 s from now
    assert s._inbox.idle()
    s.call_at(0.7, lambda now: None)
    assert s._inbox.idle()  # after a timer due sooner: the worker wakes for that one anyway
    s.call_at(0.1, lambda now: None)
    assert not s._inbox.idle()  # a worker about to wait for the 0.5 s timer looks again first


def test_a_failing_call_is_counted_and_the_service_goes_on(svc):
    s, bus, clock = svc
    s.call_at(0.1, lambda now: 1 / 0)
    clock.t = 0.2
    s.drain()
    bus.publish("zenav/r1/cmd_vel", codec.encode(m.CmdVel(t=0.2, v=0.1, omega=0.0)))
    s.drain()
    assert s.counters.values["errors"] == 1 and len(published(bus, "motors/wheels")) == 1


def test_a_clock_restart_forgets_the_calls_asked_for():
    bus, clock = MemoryBus(), SimClock()
    s = Echo(Settings.load(None), bus, clock)
    s.start()
    bus.publish("zenav/r1/clock", codec.encode(m.Clock(t=5.0, wall=0.0)))
    s.drain()
    calls = []
    s.call_at(5.1, calls.append)
    bus.publish("zenav/r1/clock", codec.encode(m.Clock(t=0.01, wall=0.0, instance="sim-2")))
    s.drain()
    for k in range(1, 12):  # the sim's new run, to past both
        bus.publish("zenav/r1/clock", codec.encode(m.Clock(t=0.5 * k, wall=0.0, instance="sim-2")))
        s.drain()
    assert calls == [] and s.counters.values["clock_resets"] == 1 and clock.now() > 5.1  # a time of the sim's previous run
    s.close()


def test_a_status_is_logged_when_it_changes_not_when_its_figures_do(svc, caplog):
    s, _, _ = svc
    with caplog.at_level("INFO", logger=s.log.name):
        s.set_status("degraded", "no VPS fix accepted for 1.5 s")
        s.set_status("degraded", "no VPS fix accepted for 2.0 s")
        s.set_status("degraded", "no VPS fix accepted for 12.5 s")
        s.set_status("degraded", "no gyro sample for 0.6 s")
        s.set_status("ok")
    logged = [r.getMessage() for r in caplog.records if "status" in r.getMessage()]
    assert logged == ["status degraded: no VPS fix accepted for 1.5 s", "status degraded: no gyro sample for 0.6 s", "status ok"]
    assert s.status_message == ""


def test_a_stray_clock_tick_from_another_sender_changes_nothing():
    bus, clock = MemoryBus(), SimClock()
    s = Echo(Settings.load(None), bus, clock)
    resets = []
    s.on_clock_reset = lambda: resets.append(clock.now())
    s.start()
    sim = bus.token("zenav/r1/instance/sim/sim-a")
    bus.publish("zenav/r1/clock", codec.encode(m.Clock(t=50.0, wall=0.0, instance="sim-a")))
    bus.publish("zenav/r1/clock", codec.encode(m.Clock(t=45.0, wall=0.0, instance="replayed-sim")))  # 5 s behind
    bus.publish("zenav/r1/clock", codec.encode(m.Clock(t=45.0, wall=0.0)))  # a client's, unnamed
    s.drain()
    assert resets == [] and s.counters.values.get("clock_resets", 0) == 0 and clock.now() >= 50.0
    assert s.counters.values["clock_foreign"] == 2 and s.counters.values["clock_refused"] == 0
    sim.undeclare()  # the sim restarted: a new instance owns the clock
    bus.token("zenav/r1/instance/sim/sim-b")
    bus.publish("zenav/r1/clock", codec.encode(m.Clock(t=0.01, wall=0.0, instance="sim-b")))
    s.drain()
    assert len(resets) == 1 and s.counters.values["clock_resets"] == 1 and clock.now() < 1.0
    s.close()
