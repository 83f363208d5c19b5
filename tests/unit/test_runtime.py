"""The service runtime on the in-memory bus with a manual clock."""

import math
import threading
import time

import msgpack
import pytest

from tests.support.echo import Echo
from zenav.common import codec, keys, runtime
from zenav.common import messages as m
from zenav.common.bus import MemoryBus
from zenav.common.clock import ManualClock, SimClock
from zenav.common.config import Settings
from zenav.common.runtime import Service, query, subscribe


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


def test_a_topic_followed_newest_keeps_its_last_sample_unserved_until_taken(svc):
    s, bus, _ = svc
    newest = s.newest("odom")
    for i in range(3):
        bus.publish(keys.key("r1", "odom"), codec.encode(i))
    assert s.counters.values["msgs_in"] == 0  # no handler, no input served
    assert newest.take() == codec.encode(2)
    assert newest.take() is None  # nothing newer came
    s.close()
    bus.publish(keys.key("r1", "odom"), codec.encode(3))
    assert newest.take() is None  # undeclared with the service


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


class Recorder(Service):
    """Records the order its handlers run in (`order`)."""

    def __init__(self, *a):
        super().__init__(*a)
        self.order = []


class Lanes(Recorder):
    """Queries in their lanes, and a topic."""

    name = "navigator"

    @query("nav/follow_path")
    def follow(self, req: m.FollowPath, q):
        self.order.append("follow")
        return m.StopReply(state="FOLLOWING_PATH")

    @query("nav/stop", priority=True)
    def stop_now(self, req: m.Empty, q):
        self.order.append("stop")
        return m.StopReply(state="STOPPED")

    @query("nav/status", acts=False)
    def status_query(self, req: m.Empty, q):
        self.order.append("status")
        return m.StopReply(state="STOPPED")

    @subscribe("pose")
    def on_pose(self, msg: m.Pose) -> None:
        self.order.append("pose")


def lanes(**limits):
    bus, clock = MemoryBus(), ManualClock()
    s = Lanes(Settings.load(None, limits=limits), bus, clock)
    s.start()
    return s, bus


def test_a_priority_query_is_taken_before_everything_queued():
    s, bus = lanes()
    path = codec.encode({"points": [[0.1 * i, 0.0] for i in range(100)]})
    held = [bus.query("zenav/r1/nav/follow_path", path) for _ in range(15)]
    bus.publish("zenav/r1/pose", codec.encode(m.Pose(t=0.0, x=0.0, y=0.0, theta=0.0, v=0.0, omega=0.0)))
    stop = bus.query("zenav/r1/nav/stop")
    assert s.drain(limit=1) == 1
    assert s.order == ["stop"] and stop.replies and not any(q.replies for q in held)
    s.drain()
    assert s.order == ["stop"] + ["follow"] * 15 + ["pose"]
    s.close()


def test_inline_a_sample_is_served_on_the_bus_thread_when_nothing_is_queued():
    s, bus = lanes()
    s.inline = True
    pose = codec.encode(m.Pose(t=0.0, x=0.0, y=0.0, theta=0.0, v=0.0, omega=0.0))
    bus.publish("zenav/r1/pose", pose)
    assert s.order == ["pose"] and s._inbox.qsize() == 0  # no worker needed
    q = bus.query("zenav/r1/nav/follow_path", codec.encode({"points": [[0.1, 0.0]]}))  # queries are queued
    bus.publish("zenav/r1/pose", pose)  # behind the query: queued, order kept
    assert s.order == ["pose"] and s._inbox.qsize() == 2
    s.drain()
    assert s.order == ["pose", "follow", "pose"] and q.replies
    s.close()


def test_inline_a_blocking_service_is_never_served_on_the_bus_thread():
    s, bus = lanes()
    s.inline, s.blocking = True, True
    bus.publish("zenav/r1/pose", codec.encode(m.Pose(t=0.0, x=0.0, y=0.0, theta=0.0, v=0.0, omega=0.0)))
    assert s.order == [] and s._inbox.qsize() == 1  # queued for its worker: a serial wait holds up no bus thread
    s.drain()
    assert s.order == ["pose"]
    s.close()


def test_inline_a_sample_waits_in_the_queue_while_the_service_is_busy():
    s, bus = lanes()
    s.inline = True
    pose = codec.encode(m.Pose(t=0.0, x=0.0, y=0.0, theta=0.0, v=0.0, omega=0.0))
    with s._busy:  # the worker (or another bus thread) is running the service
        bus.publish("zenav/r1/pose", pose)
        assert s.order == [] and s._inbox.qsize() == 1
    s.turn(8)  # the worker's next turn takes it
    assert s.order == ["pose"]
    s.close()


def test_inline_ends_at_stop_and_on_stop_runs_as_a_handler():
    s, bus = lanes()
    s.inline = True
    pose = codec.encode(m.Pose(t=0.0, x=0.0, y=0.0, theta=0.0, v=0.0, omega=0.0))
    s.stop()
    bus.publish("zenav/r1/pose", pose)
    assert s.order == [] and s._inbox.qsize() == 2  # queued behind the stop's marker, not served
    held = []
    s.on_stop = lambda: held.append(s._busy.locked())  # a bus thread cannot run a handler beside it
    s.close()
    assert held == [True]


class Overlap(Lanes):
    """Counts how many threads are inside its handler at once."""

    def __init__(self, *a):
        super().__init__(*a)
        self.inside, self.most, self.seen = 0, 0, 0

    @subscribe("pose")
    def on_pose(self, msg: m.Pose) -> None:
        self.inside += 1
        self.most = max(self.most, self.inside)
        self.seen += 1
        time.sleep(0)  # let another thread try to enter
        self.inside -= 1


def test_inline_and_worker_never_run_the_service_at_once():
    bus, clock = MemoryBus(), ManualClock()
    s = Overlap(Settings.load(None), bus, clock)
    s.inline = True
    s.start()
    worker = threading.Thread(target=s.run)
    worker.start()
    pose = codec.encode(m.Pose(t=0.0, x=0.0, y=0.0, theta=0.0, v=0.0, omega=0.0))

    def send():
        for _ in range(2000):
            bus.publish("zenav/r1/pose", pose)

    senders = [threading.Thread(target=send) for _ in range(3)]
    for t in senders:
        t.start()
    for t in senders:
        t.join(timeout=30)
    s.stop()
    worker.join(timeout=30)
    s.drain()
    assert not worker.is_alive() and s.seen == 6000 and s.most == 1
    s.close()


def test_an_acting_query_refuses_a_wildcard_and_a_read_only_one_answers_it():
    s, bus = lanes()
    q = bus.query("zenav/r1/**")
    s.drain()
    assert sorted(s.order) == ["status"]  # neither stop nor follow_path ran
    errors = [codec.decode(d, m.ErrorReply) for ok, d in q.replies if not ok]
    assert len(errors) == 2 and all(e.error == "invalid_argument" for e in errors)
    assert {e.message.rsplit(" ", 1)[-1] for e in errors} == {"zenav/r1/nav/stop", "zenav/r1/nav/follow_path"}
    assert [codec.decode(d, m.StopReply).state for ok, d in q.replies if ok] == ["STOPPED"]
    assert s.counters.values["wildcard_refused"] == 2
    exact = bus.query("zenav/r1/nav/stop")
    s.drain()
    assert exact.replies[0][0] and s.order[-1] == "stop"
    s.close()


def test_oversize_input_is_refused_before_it_is_queued():
    s, bus = lanes(max_payload=4096, max_params=1024)
    bus.publish("zenav/r1/pose", b"\x00" * 5000)
    q1 = bus.query("zenav/r1/nav/follow_path", b"\x91" * 5000)
    q2 = bus.query("zenav/r1/nav/follow_path", params={"points": "[" * 2000})
    assert s._inbox.qsize() == 0 and s.counters.values["oversize"] == 3
    for q, words in ((q1, "max_payload = 4096"), (q2, "max_params = 1024")):
        [(ok, data)] = q.replies
        err = codec.decode(data, m.ErrorReply)
        assert not ok and q.finished and err.error == "invalid_argument" and words in err.message
    s.drain()
    assert s.order == [] and s.counters.values["bad_input"] == 0
    s.close()


def test_the_queue_is_bounded_in_bytes():
    s, bus = lanes(queue_bytes=1 << 16, max_payload=40_000)
    path = codec.encode({"points": [[0.5, 0.25]] * 1500})  # about 28 kB
    qs = [bus.query("zenav/r1/nav/follow_path", path) for _ in range(3)]
    assert s._inbox.qsize() == 2 and s.counters.values["dropped_overflow"] == 1
    assert codec.decode(qs[2].replies[0][1], m.ErrorReply).error == "unavailable"
    stop = bus.query("zenav/r1/nav/stop")  # the priority lane is not held up by the bytes
    s.drain(limit=1)
    assert stop.replies[0][0]
    s.close()


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


class Held(Recorder):
    """A fix handler declared after odom, recording each fix's arrival."""

    name = "localizer"

    @subscribe("odom")
    def on_odom(self, msg: m.Odom) -> None:
        self.order.append(("odom", msg.t))

    @subscribe("sensors/imu")
    def on_imu(self, msg: m.Imu) -> None:
        self.order.append(("imu", msg.t))

    @subscribe("vps/pose", after="odom")
    def on_fix(self, msg: m.VpsPose) -> None:
        self.order.append(("fix", msg.t, self.arrived()))

    @query("localizer/pose", acts=False)
    def pose(self, req: m.Empty, q):
        self.order.append(("query",))
        return m.PoseStamped(t=0.0, x=0.0, y=0.0, theta=0.0)


@pytest.fixture
def held(monkeypatch):
    """(service served inline, bus, at): `at(t)` sets the manual stack clock and the runtime's wall clock to 100 + t."""
    wall = [100.0]
    monkeypatch.setattr(time, "monotonic", lambda: wall[0])
    bus, clock = MemoryBus(), ManualClock(0.0)
    s = Held(Settings.load(None), bus, clock)
    s.start()
    s.inline = True

    def at(t):
        clock.t, wall[0] = t, 100.0 + t

    yield s, bus, at
    s.close()


def odom(bus, t):
    bus.publish("zenav/r1/odom", codec.encode(m.Odom(t=t, x=0.0, y=0.0, theta=0.0, v=0.0, omega=0.0)))


def fix(bus, t):
    bus.publish("zenav/r1/vps/pose", codec.encode(m.VpsPose(t=t, x=0.0, y=0.0, theta=0.0)))


def test_an_input_declared_after_a_periodic_topic_is_served_in_the_gap_after_its_next_sample(held):
    s, bus, at = held
    at(5.0)
    fix(bus, 4.6)  # no odometry yet: at once
    odom(bus, 5.0)
    at(5.01)
    odom(bus, 5.01)  # odometry flows, 10 ms apart
    at(5.012)
    fix(bus, 4.7)  # held for the next sample, due at 5.02: the gap after it is from 5.025
    wait = s.turn(8)
    assert s.order == [("fix", 4.6, 5.0), ("odom", 5.0), ("odom", 5.01)] and s.diag(5.012).queue == 1
    assert wait == pytest.approx(runtime.HOLD)  # at most, if it does not come
    at(5.02)
    odom(bus, 5.02)
    at(5.024)
    assert s.turn(8) == pytest.approx(0.001)
    assert s.order[-1] == ("odom", 5.02)  # not yet
    at(5.025)
    s.turn(8)
    assert s.order[-1] == ("fix", 4.7, 5.012)  # in the gap, as of its arrival
    assert s.diag(5.025).queue == 0 and s.counters.values["msgs_in"] == 5
    fix(bus, 4.8)
    at(5.03)
    odom(bus, 5.03)
    at(5.04)
    bus.publish("zenav/r1/sensors/imu", codec.encode(m.Imu(t=5.04, gyro_z=0.0, accel_x=0.0, accel_y=0.0)))
    odom(bus, 5.04)  # the worker did not get to it: served before anything after the sample it waited for
    assert s.order[-4:] == [("odom", 5.03), ("fix", 4.8, 5.025), ("imu", 5.04), ("odom", 5.04)]


def test_held_input_is_served_before_a_query_and_not_held_once_the_topic_stops(held):
    s, bus, at = held
    for i in range(3):
        at(5.0 + 0.01 * i)
        odom(bus, 5.0 + 0.01 * i)
    fix(bus, 4.7)
    q = bus.query("zenav/r1/localizer/pose")
    s.drain()
    assert s.order[-2:] == [("fix", 4.7, 5.02), ("query",)] and q.replies
    at(5.02 + 0.8 * runtime.HOLD)
    fix(bus, 4.8)  # the next sample is late: due in the gap after the one after it
    assert s.order[-1] == ("query",)
    at(5.02 + 1.2 * runtime.HOLD)
    fix(bus, 4.9)  # odometry stopped: at once, after the one held
    assert s.order[-2:] == [("fix", 4.8, 5.02 + 0.8 * runtime.HOLD), ("fix", 4.9, 5.02 + 1.2 * runtime.HOLD)]


@pytest.fixture
def held_sim(monkeypatch):
    """(service on a sim clock, served inline, bus, wall): the monotonic clock is wall[0]."""
    wall = [100.0]
    monkeypatch.setattr(time, "monotonic", lambda: wall[0])
    bus = MemoryBus()
    s = Held(Settings.load(None), bus, SimClock())
    s.start()
    s.inline = True
    yield s, bus, wall
    s.close()


def test_on_a_sim_clock_held_input_waits_out_a_stalled_host_and_goes_with_the_ticks(held_sim):
    s, bus, wall = held_sim

    def clock(t):
        bus.publish("zenav/r1/clock", codec.encode(m.Clock(t=t, rtf=1.0)))

    for t in (5.0, 5.01):
        clock(t)
        odom(bus, t)
        wall[0] += 0.01
    fix(bus, 4.7)
    wall[0] += 0.2  # the host stalls (a replay's publisher, say): wall time passes, the clock does not
    assert 0.0 < s.turn(8) <= runtime.HOLD + 0.01  # looked at again (HOLD and a tick after it came), not released
    fix(bus, 4.8)  # odometry still flows as far as the clock says: held too
    assert s.order[-1] == ("odom", 5.01)
    clock(5.02)
    odom(bus, 5.02)
    s.drain()
    assert [o[:2] for o in s.order[-3:]] == [("odom", 5.02), ("fix", 4.7), ("fix", 4.8)]  # as at any replay speed
    # The odometry stops and the clock goes on: released at the tick HOLD and a tick interval past its
    # arrival, before what comes next.
    fix(bus, 4.9)
    for t in (5.03, 5.04, 5.05, 5.06, 5.07):
        clock(t)
    assert s.order[-1][:2] == ("fix", 4.8)
    clock(5.02 + runtime.HOLD + 0.02)
    bus.publish("zenav/r1/sensors/imu", codec.encode(m.Imu(t=5.08, gyro_z=0.0, accel_x=0.0, accel_y=0.0)))
    assert [o[:2] for o in s.order[-2:]] == [("fix", 4.9), ("imu", 5.08)]
    # The clock stops too (a paused sim): released HOLD_WALL after it came.
    clock(5.09)
    odom(bus, 5.09)
    fix(bus, 5.0)
    wall[0] += runtime.HOLD_WALL - 0.01
    assert s.turn(8) > 0.0 and s.order[-1] == ("odom", 5.09)
    wall[0] += 0.01
    s.turn(8)
    assert s.order[-1][:2] == ("fix", 5.0)


def test_held_input_waits_for_the_next_sample_across_a_tick_of_a_clock_slower_than_the_topic(held_sim):
    s, bus, wall = held_sim
    for k in range(3):  # the sim's clock at 20 Hz, odometry at 100 Hz
        bus.publish("zenav/r1/clock", codec.encode(m.Clock(t=round(3.41 + 0.05 * k, 2), rtf=1.0)))
        for i in range(5):
            odom(bus, round(3.41 + 0.05 * k + 0.01 * i, 2))
            wall[0] += 0.01
    fix(bus, 3.2)  # after the last sample before a tick
    bus.publish("zenav/r1/clock", codec.encode(m.Clock(t=3.56, rtf=1.0)))
    odom(bus, 3.56)
    s.drain()
    assert [o[:2] for o in s.order[-2:]] == [("odom", 3.56), ("fix", 3.2)]  # not released by the tick


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
