"""The motor service on the in-memory bus with a manual clock."""

import math

import msgpack
import pytest

from tests.support.rig import Rig
from zenav.common import codec
from zenav.common import messages as m
from zenav.common.app import main
from zenav.common.bus import MemoryBus
from zenav.common.clock import ManualClock, SimClock
from zenav.common.config import ConfigError, Settings
from zenav.services.motor.service import Motor

R, L = 0.0673 / 2.0, 0.1156


def make(t0=10.0, **sections):
    return Rig(Motor, t0=t0, **sections)


def send(rig, v, omega, t):
    rig.put("cmd_vel", m.CmdVel(t=t, v=v, omega=omega))


def test_command_to_wheels_with_the_command_t():
    rig = make(motor={"max_wheel_accel": 1e4})
    send(rig, 0.1, 0.5, t=rig.t - 0.02)
    [w] = rig.got("motors/wheels")
    assert w.t == rig.t - 0.02
    assert (w.left, w.right) == pytest.approx(((0.1 - 0.5 * L / 2) / R, (0.1 + 0.5 * L / 2) / R))


def test_a_motor_behind_its_commands_runs_only_the_newest(caplog):
    rig = make(motor={"max_wheel_accel": 1e4})
    for i, v in enumerate((0.1, 0.2, 0.3)):  # three commands come before the motor gets to any
        rig.bus.publish(rig.key("cmd_vel"), codec.encode(m.CmdVel(t=rig.t - 0.02 + i * 0.01, v=v, omega=0.0)))
    assert rig.svc._inbox.qsize() == 1
    rig.drain()
    [w] = rig.got("motors/wheels")  # no command run late, one after another
    assert w.t == pytest.approx(rig.t) and (w.left, w.right) == pytest.approx((0.3 / R, 0.3 / R))
    c = rig.svc.counters.values
    assert c["dropped_superseded"] == 2 and c["msgs_in"] == 1
    assert "dropped a cmd_vel sample for a newer one: motor is slower than its input" in caplog.text


def test_saturation_keeps_the_curvature():
    rig = make(motor={"max_wheel_accel": 1e4})
    send(rig, 0.5, 3.0, t=rig.t)  # right wheel would need 20 rad/s
    [w] = rig.got("motors/wheels")
    left, right = (0.5 - 3.0 * L / 2) / R, (0.5 + 3.0 * L / 2) / R
    assert w.right == pytest.approx(10.0) and w.left / w.right == pytest.approx(left / right)


def test_acceleration_is_limited_over_clock_time():
    rig = make(motor={"max_wheel_accel": 40.0})
    outs = []
    for _ in range(30):
        send(rig, 0.3, 0.0, t=rig.t)
        outs.append(rig.got("motors/wheels")[-1].left)
        rig.advance(0.01)
    steps = [b - a for a, b in zip(outs, outs[1:])]
    assert outs[0] == pytest.approx(4.0)  # first command from rest: 40 rad/s^2 over max_accel_dt 0.1 s
    assert max(steps) == pytest.approx(0.4)  # 40 rad/s^2 x 10 ms
    assert outs[-1] == pytest.approx(0.3 / R)


def test_stop_command_is_not_ramped():
    rig = make(motor={"max_wheel_accel": 1e4})
    send(rig, 0.3, 0.0, t=rig.t)
    rig.advance(0.01)
    send(rig, 0.0, 0.0, t=rig.t)
    assert (rig.got("motors/wheels")[-1].left, rig.got("motors/wheels")[-1].right) == (0.0, 0.0)


def test_slow_command_is_raised_to_the_deadband():
    rig = make()
    send(rig, 0.005, 0.0, t=rig.t)
    assert (rig.got("motors/wheels")[-1].left, rig.got("motors/wheels")[-1].right) == (0.5, 0.5)


def test_watchdog_stops_once_after_half_a_second():
    rig = make()
    send(rig, 0.2, 0.0, t=rig.t)
    t_cmd = rig.t
    rig.run(0.45)
    assert len(rig.got("motors/wheels")) == 1
    rig.run(0.2)
    ws = rig.got("motors/wheels")
    assert len(ws) == 2 and (ws[1].left, ws[1].right) == (0.0, 0.0)
    assert 0.5 < ws[1].t - t_cmd <= 0.5 + 0.05 + 1e-9  # within one watchdog period
    rig.run(2.0)
    assert len(rig.got("motors/wheels")) == 2 and rig.svc.counters.values["watchdog_stops"] == 1


def test_watchdog_quiet_while_commands_flow_and_when_idle():
    rig = make()
    rig.run(1.0)  # never commanded: nothing to stop
    for _ in range(100):
        send(rig, 0.2, 0.0, t=rig.t)
        rig.advance(0.02)
    send(rig, 0.0, 0.0, t=rig.t)  # stopped by command
    rig.run(1.0)
    assert rig.svc.counters.values["watchdog_stops"] == 0 and len(rig.got("motors/wheels")) == 101


def test_stale_command_is_rejected_and_t_zero_means_now():
    rig = make()
    send(rig, 0.2, 0.0, t=rig.t - 0.6)
    assert rig.got("motors/wheels") == [] and rig.svc.counters.values["dropped_stale"] == 1
    send(rig, 0.2, 0.0, t=0.0)
    [w] = rig.got("motors/wheels")
    assert w.t == 0.0 and w.left > 0.0


def test_bad_command_is_dropped_by_decoding():
    rig = make()
    rig.put("cmd_vel", msgpack.packb({"t": rig.t, "v": math.nan, "omega": 0.0}))
    assert rig.got("motors/wheels") == [] and rig.svc.counters.values["bad_input"] == 1


def test_zero_on_close():
    rig = make()
    send(rig, 0.2, 0.5, t=rig.t)
    rig.close()
    last = rig.got("motors/wheels")[-1]
    assert (last.left, last.right) == (0.0, 0.0) and rig.bus.alive() == []


@pytest.mark.parametrize("command_after_restart", [True, False])
def test_sim_restart_keeps_limits_and_watchdog_working(command_after_restart):
    rig = Rig(Motor, clock=SimClock(), motor={"max_wheel_accel": 40.0})

    def tick(t, instance="sim-2"):
        rig.put("clock", m.Clock(t=t, instance=instance))

    tick(100.0, "sim-1")
    send(rig, 0.2, 0.0, t=100.0)
    tick(0.5)  # a new sim instance: the sim restarted, time starts again
    if command_after_restart:
        send(rig, 0.2, 0.0, t=0.5)
        first, second = rig.got("motors/wheels")
        assert first.left == pytest.approx(4.0)  # 40 rad/s^2 x 0.1 s from rest
        assert second.left > first.left  # ramps on: no negative elapsed time froze it
    for i in range(1, 61):
        tick(0.5 + i * 0.01)
    assert rig.svc.counters.values["watchdog_stops"] == 1 and rig.got("motors/wheels")[-1].left == 0.0
    rig.close()


def test_bad_config_names_the_key():
    with pytest.raises(ConfigError, match="watchdog"):
        Motor(Settings.load(None, motor={"watchdog": -1.0}), MemoryBus(), ManualClock())


def test_help(capsys):
    with pytest.raises(SystemExit) as e:
        main(Motor, ["--help"])
    assert e.value.code == 0 and "zenav-motor" in capsys.readouterr().out


def test_no_sim_nor_driver_is_an_error():
    rig = make()
    sim = rig.bus.token("zenav/r1/alive/sim")
    rig.drain()
    assert rig.svc.status == "ok"
    sim.undeclare()
    rig.drain()
    assert rig.svc.status == "error" and "sim gone: wheel commands reach no wheels" in rig.svc.status_message
    driver = rig.bus.token("zenav/r1/alive/driver")  # a real robot's board instead
    rig.drain()
    assert rig.svc.status == "ok"
    driver.undeclare()
    rig.drain()
    assert rig.svc.status == "error" and rig.svc.status_message.startswith("driver gone")


def test_stops_at_once_when_the_navigator_process_goes():
    rig = make()
    nav = rig.bus.token("zenav/r1/alive/navigator")
    send(rig, 0.2, 0.0, rig.t)
    assert rig.got("motors/wheels")[-1].left > 0
    nav.undeclare()  # kill -9: the token goes with the socket, long before the watchdog
    rig.drain()
    assert (rig.got("motors/wheels")[-1].left, rig.got("motors/wheels")[-1].right) == (0.0, 0.0)
    assert rig.svc.counters.values["navigator_lost_stops"] == 1
    rig.bus.token("zenav/r1/alive/navigator")  # a new navigator: nothing to do while stopped
    rig.drain()
    assert rig.svc.counters.values["navigator_lost_stops"] == 1
