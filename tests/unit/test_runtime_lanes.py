"""Queries in their lanes (a priority query ahead of everything queued), input served inline on the bus's thread,
and the bounds on what may be queued, on the in-memory bus."""

import threading
import time

from tests.support.recorder import Recorder
from zenav.common import codec
from zenav.common import messages as m
from zenav.common.bus import MemoryBus
from zenav.common.clock import ManualClock
from zenav.common.config import Settings
from zenav.common.runtime import query, subscribe


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
