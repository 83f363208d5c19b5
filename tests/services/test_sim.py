"""The sim service on the in-memory bus with a manual clock."""
import math

import msgpack
import pytest

from zenav.common import codec, keys
from zenav.common import messages as m
from zenav.common.app import main
from zenav.common.bus import MemoryBus
from zenav.common.clock import ManualClock, ScaledWallClock
from zenav.common.config import ConfigError, Settings
from zenav.services.sim.service import Sim, SimConfig

SENSOR_TOPICS = ("sim/truth", "sensors/encoders", "sensors/imu", "sensors/compass")


def make(**sections):
    bus, clock = MemoryBus(), ManualClock()
    sim = Sim(Settings.load(None, **sections), bus, clock)
    sim.start()
    sim.drain()
    return sim, bus, clock


def run(sim, clock, seconds, dt=0.01):
    """Advance the clock in ticks of dt, draining after each."""
    for _ in range(round(seconds / dt)):
        clock.advance(dt)
        sim.drain()


def published(bus, suffix):
    typ = keys.TOPICS[suffix]
    return [codec.decode(d, typ) for k, d in bus.published if k == keys.key("r1", suffix)]


def command(bus, left, right, t=0.0):
    bus.publish("zenav/r1/motors/wheels", codec.encode(m.Wheels(t=t, left=left, right=right)))


def reset(sim, bus, **req):
    q = bus.query("zenav/r1/sim/reset", codec.encode(req))
    sim.drain()
    [(ok, data)] = q.replies
    assert ok and q.finished
    return codec.decode(data, m.PoseStamped)


def test_rates_over_one_second_of_sim_time():
    sim, bus, clock = make()
    run(sim, clock, 1.0)
    for suffix in ("clock", "sim/truth", "sensors/encoders", "sensors/imu"):
        msgs = published(bus, suffix)
        assert len(msgs) == 100, suffix
        assert [x.t for x in msgs] == pytest.approx([i / 100 for i in range(1, 101)])
    compass = published(bus, "sensors/compass")
    assert [c.t for c in compass] == pytest.approx([i / 10 for i in range(1, 11)])
    clocks = published(bus, "clock")
    assert all(c.rtf == 1.0 and c.wall > 0 for c in clocks)
    assert sim.counters.values["overruns"] == 0


def test_rates_follow_the_scenario():
    sim, bus, clock = make(scenario={"sensor_rate_hz": 50.0, "compass_rate_hz": 4.0})
    run(sim, clock, 1.0, dt=0.02)
    assert len(published(bus, "sensors/encoders")) == 50
    assert len(published(bus, "sensors/compass")) == 4


def test_fixed_steps_catch_up_a_late_tick():
    sim, bus, clock = make()
    clock.advance(0.3)  # one late tick: thirty steps of 10 ms, same times as on schedule
    sim.drain()
    assert [x.t for x in published(bus, "sim/truth")] == pytest.approx([i / 100 for i in range(1, 31)])
    assert sim.counters.values["overruns"] == 0


def test_burst_is_bounded_then_resyncs():
    sim, bus, clock = make()
    clock.advance(2.0)  # a stall: at most 50 steps, the rest of the time is dropped
    sim.drain()
    assert len(published(bus, "clock")) == 50 and sim.counters.values["overruns"] == 1
    run(sim, clock, 0.1)  # back on schedule from the resync, no more bursts
    assert len(published(bus, "clock")) == 60 and sim.counters.values["overruns"] == 1
    assert published(bus, "clock")[-1].t == pytest.approx(0.6)


def test_wheel_commands_drive_the_robot():
    sim, bus, clock = make()
    for _ in range(100):  # commands at 100 Hz, as the motor service sends them
        command(bus, 5.0, 5.0)
        run(sim, clock, 0.01)
    truth = published(bus, "sim/truth")[-1]
    r = 0.0673 / 2
    assert truth.x == pytest.approx(r * 5.0 * 0.95, rel=0.05)  # 50 ms motor lag
    assert truth.v == pytest.approx(r * 5.0, rel=0.05)
    enc = published(bus, "sensors/encoders")[-1]
    # The first command lands after the first step; then 50 ms of lag.
    assert enc.left == enc.right == pytest.approx(5.0 * (0.99 - 0.05) / (2 * math.pi) * 360, abs=1)


def test_command_timeout_stops_the_wheels():
    sim, bus, clock = make()
    command(bus, -5.0, 5.0)
    run(sim, clock, 0.4)
    assert published(bus, "sim/truth")[-1].omega > 1.0
    run(sim, clock, 0.6)
    truth = published(bus, "sim/truth")
    assert abs(truth[-1].omega) < 1e-3 and abs(truth[-1].v) < 1e-3
    assert sim.counters.values["command_timeouts"] == 1
    omega = {round(x.t, 2): x.omega for x in truth}
    assert omega[0.5] > 2.5 and omega[0.65] < 0.3  # full speed until the timeout, then the 50 ms lag


def test_reset_teleports_and_stops():
    sim, bus, clock = make(sim={"x0": 0.2, "theta0": 0.1})
    command(bus, 6.0, 6.0)
    run(sim, clock, 0.3)
    before = published(bus, "sim/truth")[-1]
    assert before.x > 0.2
    pose = reset(sim, bus, x=1.0, y=2.0, theta=3.0)
    assert (pose.t, pose.x, pose.y, pose.theta) == (pytest.approx(0.3), 1.0, 2.0, 3.0)
    run(sim, clock, 0.01)
    after = published(bus, "sim/truth")[-1]
    assert (after.x, after.y, after.theta) == (1.0, 2.0, 3.0) and after.v == 0.0  # wheels stopped
    pose = reset(sim, bus, y=-1.0)  # unset fields keep the current pose
    assert (pose.x, pose.y, pose.theta) == (1.0, -1.0, 3.0)


def test_reset_by_selector_parameters_and_bad_request():
    sim, bus, clock = make()
    q = bus.query("zenav/r1/sim/reset", params={"x": "0.5", "seed": "3"})
    sim.drain()
    assert codec.decode(q.replies[0][1], m.PoseStamped).x == 0.5
    q = bus.query("zenav/r1/sim/reset", codec.encode({"x": 1.0, "sead": 3}))
    sim.drain()
    [(ok, data)] = q.replies
    assert not ok and codec.decode(data, m.ErrorReply).error == "invalid_argument"


def sensor_stream(seed_at_start, reset_seed):
    sim, bus, clock = make(deployment={"seed": seed_at_start, "scenario": "harsh"})
    run(sim, clock, 0.2)
    reset(sim, bus, x=0.4, y=0.5, theta=0.0, seed=reset_seed)
    start = len(bus.published)
    for i in range(100):
        command(bus, 6.0 + (i % 7), 4.0)
        run(sim, clock, 0.01)
    return [(k, d) for k, d in bus.published[start:] if k.split("/", 2)[2] in SENSOR_TOPICS]


def test_reset_reseeds_so_runs_repeat():
    a = sensor_stream(1, reset_seed=42)
    b = sensor_stream(2, reset_seed=42)  # other seed before the reset: same run after it
    assert len(a) == 310 and a == b
    assert sensor_stream(1, reset_seed=43) != a


def test_encoders_wrap_from_a_large_start():
    sim, bus, clock = make(sim={"encoder_start": 2**31 - 10})
    command(bus, 10.0, -10.0)
    run(sim, clock, 0.2)
    left = [e.left for e in published(bus, "sensors/encoders")]
    right = [e.right for e in published(bus, "sensors/encoders")]
    assert left[0] >= 2**31 - 10 and left[-1] < 0  # wrapped past +2^31 - 1
    assert right[-1] < 2**31 - 10 and right[-1] > 0  # counting down: no wrap


@pytest.mark.parametrize(
    "payload",
    [b"\xc1", msgpack.packb({"t": 0.0, "left": "fast", "right": 1.0}), msgpack.packb({"t": 0.0, "left": math.inf, "right": 1.0})],
)
def test_bad_wheels_payload_is_counted_and_ignored(payload):
    sim, bus, clock = make()
    bus.publish("zenav/r1/motors/wheels", payload)
    run(sim, clock, 0.2)
    assert sim.counters.values["bad_input"] == 1
    assert published(bus, "sim/truth")[-1].v == 0.0
    command(bus, 5.0, 5.0)
    run(sim, clock, 0.2)
    assert published(bus, "sim/truth")[-1].v > 0.1


def test_diag_reports_rates_and_counters():
    sim, bus, clock = make()
    run(sim, clock, 1.0)
    clock.advance(0.001)
    sim.drain()
    [diag] = published(bus, "diag/sim")
    assert diag.rates["clock"] == pytest.approx(100.0, rel=0.02)
    assert diag.rates["sensors/compass"] == pytest.approx(10.0, rel=0.02)
    assert diag.counters["overruns"] == 0 and diag.counters["command_timeouts"] == 0
    assert bus.alive() == ["zenav/r1/alive/sim"]


def test_make_clock_scales_wall_time():
    clock = Sim.make_clock(Settings.load(None, sim={"rtf": 5.0}))
    assert isinstance(clock, ScaledWallClock) and clock.rtf == 5.0
    assert clock.wall_delay(0.01) == pytest.approx(0.002)


@pytest.mark.parametrize("bad", [{"rtf": 1000.0}, {"rtf": 0.0}, {"command_timeout": 0.0}, {"speed": 1.0}])
def test_bad_config_fails_fast(bad):
    with pytest.raises(ConfigError, match="sim"):
        Settings.load(None, sim=bad).section("sim", SimConfig)


def test_help(capsys):
    with pytest.raises(SystemExit) as e:
        main(Sim, ["--help"])
    assert e.value.code == 0 and "zenav-sim" in capsys.readouterr().out


def test_wheels_stop_at_once_when_the_motor_service_goes():
    from zenav.common import codec
    from zenav.common import messages as m
    from zenav.common.bus import MemoryBus
    from zenav.common.clock import ManualClock
    from zenav.common.config import Settings
    from zenav.services.sim.service import Sim

    bus, clock = MemoryBus(), ManualClock()
    sim = Sim(Settings.load(None), bus, clock)
    sim.start()
    motor = bus.token("zenav/r1/alive/motor")
    for _ in range(30):  # 0.3 s driving
        bus.publish("zenav/r1/motors/wheels", codec.encode(m.Wheels(t=0.0, left=5.0, right=5.0)))
        clock.advance(0.01)
        sim.drain()
    assert sim.cmd == (5.0, 5.0)
    motor.undeclare()
    sim.drain()
    assert sim.cmd == (0.0, 0.0) and sim.counters.values["motor_lost_stops"] == 1
    sim.close()
