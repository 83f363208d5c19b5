"""The motor service on the in-memory bus with a manual clock."""
import math

import msgpack
import pytest

from zenav.common import codec, keys
from zenav.common import messages as m
from zenav.common.app import main
from zenav.common.bus import MemoryBus
from zenav.common.clock import ManualClock, SimClock
from zenav.common.config import ConfigError, Settings
from zenav.services.motor.service import Motor

R, L = 0.0673 / 2.0, 0.1156


def make(t0=10.0, **sections):
    bus, clock = MemoryBus(), ManualClock(t0)
    svc = Motor(Settings.load(None, **sections), bus, clock)
    svc.start()
    svc.drain()
    return svc, bus, clock


def wheels(bus):
    return [codec.decode(d, m.Wheels) for k, d in bus.published if k == keys.key("r1", "motors/wheels")]


def send(svc, bus, v, omega, t):
    bus.publish("zenav/r1/cmd_vel", codec.encode(m.CmdVel(t=t, v=v, omega=omega)))
    svc.drain()


def run(svc, clock, seconds, dt=0.01):
    for _ in range(round(seconds / dt)):
        clock.advance(dt)
        svc.drain()


def test_command_to_wheels_with_the_command_t():
    svc, bus, clock = make(motor={"max_wheel_accel": 1e4})
    send(svc, bus, 0.1, 0.5, t=clock.t - 0.02)
    [w] = wheels(bus)
    assert w.t == clock.t - 0.02
    assert (w.left, w.right) == pytest.approx(((0.1 - 0.5 * L / 2) / R, (0.1 + 0.5 * L / 2) / R))


def test_saturation_keeps_the_curvature():
    svc, bus, clock = make(motor={"max_wheel_accel": 1e4})
    send(svc, bus, 0.5, 3.0, t=clock.t)  # right wheel would need 20 rad/s
    [w] = wheels(bus)
    left, right = (0.5 - 3.0 * L / 2) / R, (0.5 + 3.0 * L / 2) / R
    assert w.right == pytest.approx(10.0) and w.left / w.right == pytest.approx(left / right)


def test_acceleration_is_limited_over_clock_time():
    svc, bus, clock = make(motor={"max_wheel_accel": 40.0})
    outs = []
    for _ in range(30):
        send(svc, bus, 0.3, 0.0, t=clock.t)
        outs.append(wheels(bus)[-1].left)
        clock.advance(0.01)
    steps = [b - a for a, b in zip(outs, outs[1:])]
    assert outs[0] == pytest.approx(4.0)  # first command from rest: 40 rad/s^2 over max_accel_dt 0.1 s
    assert max(steps) == pytest.approx(0.4)  # 40 rad/s^2 x 10 ms
    assert outs[-1] == pytest.approx(0.3 / R)


def test_stop_command_is_not_ramped():
    svc, bus, clock = make(motor={"max_wheel_accel": 1e4})
    send(svc, bus, 0.3, 0.0, t=clock.t)
    clock.advance(0.01)
    send(svc, bus, 0.0, 0.0, t=clock.t)
    assert (wheels(bus)[-1].left, wheels(bus)[-1].right) == (0.0, 0.0)


def test_slow_command_is_raised_to_the_deadband():
    svc, bus, clock = make()
    send(svc, bus, 0.005, 0.0, t=clock.t)
    assert (wheels(bus)[-1].left, wheels(bus)[-1].right) == (0.5, 0.5)


def test_watchdog_stops_once_after_half_a_second():
    svc, bus, clock = make()
    send(svc, bus, 0.2, 0.0, t=clock.t)
    t_cmd = clock.t
    run(svc, clock, 0.45)
    assert len(wheels(bus)) == 1
    run(svc, clock, 0.2)
    ws = wheels(bus)
    assert len(ws) == 2 and (ws[1].left, ws[1].right) == (0.0, 0.0)
    assert 0.5 < ws[1].t - t_cmd <= 0.5 + 0.05 + 1e-9  # within one watchdog period
    run(svc, clock, 2.0)
    assert len(wheels(bus)) == 2 and svc.counters.values["watchdog_stops"] == 1


def test_watchdog_quiet_while_commands_flow_and_when_idle():
    svc, bus, clock = make()
    run(svc, clock, 1.0)  # never commanded: nothing to stop
    for _ in range(100):
        send(svc, bus, 0.2, 0.0, t=clock.t)
        clock.advance(0.02)
    send(svc, bus, 0.0, 0.0, t=clock.t)  # stopped by command
    run(svc, clock, 1.0)
    assert svc.counters.values["watchdog_stops"] == 0 and len(wheels(bus)) == 101


def test_stale_command_is_rejected_and_t_zero_means_now():
    svc, bus, clock = make()
    send(svc, bus, 0.2, 0.0, t=clock.t - 0.6)
    assert wheels(bus) == [] and svc.counters.values["dropped_stale"] == 1
    send(svc, bus, 0.2, 0.0, t=0.0)
    [w] = wheels(bus)
    assert w.t == 0.0 and w.left > 0.0


def test_bad_command_is_dropped_by_decoding():
    svc, bus, clock = make()
    bus.publish("zenav/r1/cmd_vel", msgpack.packb({"t": clock.t, "v": math.nan, "omega": 0.0}))
    svc.drain()
    assert wheels(bus) == [] and svc.counters.values["bad_input"] == 1


def test_zero_on_close():
    svc, bus, clock = make()
    send(svc, bus, 0.2, 0.5, t=clock.t)
    svc.close()
    last = wheels(bus)[-1]
    assert (last.left, last.right) == (0.0, 0.0) and bus.alive() == []


@pytest.mark.parametrize("command_after_restart", [True, False])
def test_sim_restart_keeps_limits_and_watchdog_working(command_after_restart):
    bus, clock = MemoryBus(), SimClock()
    svc = Motor(Settings.load(None, motor={"max_wheel_accel": 40.0}), bus, clock)
    svc.start()

    def tick(t):
        bus.publish("zenav/r1/clock", codec.encode(m.Clock(t=t)))
        svc.drain()

    tick(100.0)
    send(svc, bus, 0.2, 0.0, t=100.0)
    tick(0.5)  # the sim restarted: time starts again
    if command_after_restart:
        send(svc, bus, 0.2, 0.0, t=0.5)
        first, second = wheels(bus)
        assert first.left == pytest.approx(4.0)  # 40 rad/s^2 x 0.1 s from rest
        assert second.left > first.left  # ramps on: no negative elapsed time froze it
    for i in range(1, 61):
        tick(0.5 + i * 0.01)
    assert svc.counters.values["watchdog_stops"] == 1 and wheels(bus)[-1].left == 0.0
    svc.close()


def test_bad_config_names_the_key():
    with pytest.raises(ConfigError, match="watchdog"):
        Motor(Settings.load(None, motor={"watchdog": -1.0}), MemoryBus(), ManualClock())


def test_help(capsys):
    with pytest.raises(SystemExit) as e:
        main(Motor, ["--help"])
    assert e.value.code == 0 and "zenav-motor" in capsys.readouterr().out


def test_stops_at_once_when_the_navigator_process_goes():
    svc, bus, clock = make()
    nav = bus.token("zenav/r1/alive/navigator")
    send(svc, bus, 0.2, 0.0, clock.now())
    assert wheels(bus)[-1].left > 0
    nav.undeclare()  # kill -9: the token goes with the socket, long before the watchdog
    svc.drain()
    assert (wheels(bus)[-1].left, wheels(bus)[-1].right) == (0.0, 0.0)
    assert svc.counters.values["navigator_lost_stops"] == 1
    bus.token("zenav/r1/alive/navigator")  # a new navigator: nothing to do while stopped
    svc.drain()
    assert svc.counters.values["navigator_lost_stops"] == 1
