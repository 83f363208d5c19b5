"""Held input on the in-memory bus: a topic declared `after` a periodic one is served in the gap after that topic's
next sample (the runtime's pacing), on a manual and on a sim clock, and released when the topic or the clock stops."""

import time

import pytest

from tests.support.recorder import Recorder
from zenav.common import codec, runtime
from zenav.common import messages as m
from zenav.common.bus import MemoryBus
from zenav.common.clock import ManualClock, SimClock
from zenav.common.config import Settings
from zenav.common.runtime import query, subscribe


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
