"""The sim service on the in-memory bus with a manual clock."""

import math

import msgpack
import msgspec
import pytest

from tests.support.rig import Rig
from zenav.common import codec
from zenav.common import messages as m
from zenav.common.app import main
from zenav.common.clock import ScaledWallClock
from zenav.common.config import ConfigError, Settings
from zenav.services.sim.service import Sim, SimConfig

SENSOR_TOPICS = ("sim/truth", "sensors/encoders", "sensors/imu", "sensors/compass")


def command(rig, left, right, t=0.0):
    """Send wheel commands, taken at the sim's next drain."""
    rig.bus.publish(rig.key("motors/wheels"), codec.encode(m.Wheels(t=t, left=left, right=right)))


def settle(rig):
    """Half a step on: the last step's clock tick and truth, which follow its sensors by that much, are out."""
    rig.advance(rig.svc.tick_period)


def reset(rig, **req):
    pose = rig.reply(rig.query("sim/reset", req))
    assert isinstance(pose, m.PoseStamped)
    return pose


def test_rates_over_one_second_of_sim_time():
    rig = Rig(Sim)
    rig.run(1.0)
    settle(rig)
    for suffix in ("sim/truth", "sensors/encoders", "sensors/imu"):
        msgs = rig.got(suffix)
        assert len(msgs) == 100, suffix
        assert [x.t for x in msgs] == pytest.approx([i / 100 for i in range(1, 101)])
    compass = rig.got("sensors/compass")
    assert [c.t for c in compass] == pytest.approx([i / 10 for i in range(1, 11)])
    clocks = rig.got("clock")  # [sim] clock_rate_hz = 20, from the first step
    assert [c.t for c in clocks] == pytest.approx([0.01 + i / 20 for i in range(20)])
    assert all(c.rtf == 1.0 and c.wall > 0 for c in clocks)
    assert all(x.wall > 0 for x in rig.got("sim/truth"))


def test_the_clock_ticks_at_its_rate_up_to_every_step():
    rig = Rig(Sim, sim={"clock_rate_hz": 1000.0})
    rig.run(0.1)
    settle(rig)
    assert [c.t for c in rig.got("clock")] == pytest.approx([i / 100 for i in range(1, 11)])
    assert rig.svc.counters.values["overruns"] == 0


def test_a_steps_clock_tick_and_truth_follow_its_sensors_by_half_a_step():
    """So that they wake no process while the step's sample goes through the control chain."""
    rig = Rig(Sim, sim={"clock_rate_hz": 100.0})
    rig.advance(0.01)
    assert [x.t for x in rig.got("sensors/encoders")] == [0.01] and [x.t for x in rig.got("sensors/imu")] == [0.01]
    assert rig.got("sim/truth") == [] and rig.got("clock") == []
    settle(rig)
    assert [x.t for x in rig.got("sim/truth")] == [0.01] and [c.t for c in rig.got("clock")] == [0.01]
    assert len(rig.got("sensors/encoders")) == 1  # no step taken on the half
    truth, clock = rig.got("sim/truth")[0], rig.got("clock")[0]
    assert truth.wall == clock.wall > 0  # the sample's instant, when its sensors were read


def test_a_steps_gyro_sample_goes_out_before_its_encoders():
    """So that the odom sample the encoders become finds its gyro sample at the localizer, also where
    both come down one link read in order (the robot's services composed in one process)."""
    rig = Rig(Sim)
    rig.run(0.05)
    sensors = {rig.key("sensors/imu"): ("imu", m.Imu), rig.key("sensors/encoders"): ("encoders", m.Encoders)}
    sent = [(sensors[k][0], round(codec.decode(d, sensors[k][1]).t, 6)) for k, d in rig.bus.published if k in sensors]
    assert sent == [(name, i / 100) for i in range(1, 6) for name in ("imu", "encoders")]


def test_rates_follow_the_scenario():
    rig = Rig(Sim, scenario={"sensor_rate_hz": 50.0, "compass_rate_hz": 4.0})
    rig.run(1.0, dt=0.02)
    assert len(rig.got("sensors/encoders")) == 50
    assert len(rig.got("sensors/compass")) == 4


def test_fixed_steps_catch_up_a_late_tick():
    rig = Rig(Sim)
    rig.advance(0.3)  # one late tick: thirty steps of 10 ms, same times as on schedule
    settle(rig)
    assert [x.t for x in rig.got("sim/truth")] == pytest.approx([i / 100 for i in range(1, 31)])
    assert rig.svc.counters.values["overruns"] == 0


def test_a_catch_up_sends_each_steps_clock_tick_before_the_next_steps_sensors():
    """A services' clock admits a sample up to one tick ahead: a burst's samples must not outrun its ticks."""
    rig = Rig(Sim, sim={"clock_rate_hz": 100.0})
    rig.advance(0.3)  # one late tick: thirty steps at once
    settle(rig)
    clock, ahead = -1.0, []
    for key, data in rig.bus.published:
        if key == rig.key("clock"):
            clock = codec.decode(data, m.Clock).t
        elif key == rig.key("sensors/encoders"):
            ahead.append(round(codec.decode(data, m.Encoders).t - clock, 6))
    assert ahead == [0.01 + 1.0] + [0.01] * 29  # the first before any tick


def test_burst_is_bounded_then_resyncs():
    rig = Rig(Sim)
    rig.advance(2.0)  # a stall: at most 50 steps, the rest of the time is dropped
    settle(rig)
    assert len(rig.got("sim/truth")) == 50 and rig.svc.counters.values["overruns"] == 1
    rig.run(0.1)  # back on schedule from the resync, no more bursts
    settle(rig)
    assert len(rig.got("sim/truth")) == 60 and rig.svc.counters.values["overruns"] == 1
    assert rig.got("sim/truth")[-1].t == pytest.approx(0.6)


def test_falling_behind_is_degraded_for_a_while_then_ok():
    rig = Rig(Sim)
    rig.run(1.0)
    assert rig.got("diag/sim")[-1].status == "ok"
    rig.advance(2.0)  # a stall longer than max_burst steps
    rig.run(1.0)
    d = rig.got("diag/sim")[-1]
    assert d.status == "degraded" and "fell 200 steps behind" in d.message and "rtf 1" in d.message
    rig.run(5.0)  # on schedule again
    assert rig.got("diag/sim")[-1].status == "ok"


def test_failing_camera_frames_are_an_error_until_one_is_sent():
    rig = Rig(Sim, sim={"camera": True}, camera={"width": 160, "height": 120, "fx": 133.25, "fy": 133.25})
    assert rig.svc.shutter is not None
    send = rig.svc.shutter.send
    rig.svc.shutter.send = lambda frame: 1 / 0
    for _ in range(100):
        rig.advance(0.01)
        assert rig.svc.shutter.idle(10.0)
    d = rig.got("diag/sim")[-1]
    assert d.status == "error" and "camera frames fail: ZeroDivisionError" in d.message
    assert d.counters["frames_failed"] == 10
    rig.svc.shutter.send = send
    for _ in range(100):
        rig.advance(0.01)
        assert rig.svc.shutter.idle(10.0)
    assert rig.got("diag/sim")[-1].status == "ok" and rig.svc.counters.values["frames_failed"] == 10
    rig.close()


def test_wheel_commands_drive_the_robot():
    rig = Rig(Sim)
    for _ in range(100):  # commands at 100 Hz, as the motor service sends them
        command(rig, 5.0, 5.0)
        rig.run(0.01)
    truth = rig.got("sim/truth")[-1]
    r = 0.0673 / 2
    assert truth.x == pytest.approx(r * 5.0 * 0.95, rel=0.05)  # 50 ms motor lag
    assert truth.v == pytest.approx(r * 5.0, rel=0.05)
    enc = rig.got("sensors/encoders")[-1]
    # The first command lands after the first step; then 50 ms of lag.
    assert enc.left == enc.right == pytest.approx(5.0 * (0.99 - 0.05) / (2 * math.pi) * 360, abs=1)


def test_command_timeout_stops_the_wheels():
    rig = Rig(Sim)
    command(rig, -5.0, 5.0)
    rig.run(0.4)
    assert rig.got("sim/truth")[-1].omega > 1.0
    enc = rig.got("sensors/encoders")[-1]
    assert (enc.cmd_left, enc.cmd_right) == (-5.0, 5.0)  # each sample says what its wheels were commanded
    rig.run(0.6)
    truth = rig.got("sim/truth")
    assert abs(truth[-1].omega) < 1e-3 and abs(truth[-1].v) < 1e-3
    enc = rig.got("sensors/encoders")[-1]
    assert (enc.cmd_left, enc.cmd_right) == (0.0, 0.0)
    assert rig.svc.counters.values["command_timeouts"] == 1
    omega = {round(x.t, 2): x.omega for x in truth}
    assert omega[0.5] > 2.5 and omega[0.65] < 0.3  # full speed until the timeout, then the 50 ms lag


def test_reset_teleports_and_stops():
    rig = Rig(Sim, sim={"x0": 0.2, "theta0": 0.1})
    command(rig, 6.0, 6.0)
    rig.run(0.3)
    before = rig.got("sim/truth")[-1]
    assert before.x > 0.2
    pose = reset(rig, x=1.0, y=2.0, theta=3.0)
    assert (pose.t, pose.x, pose.y, pose.theta) == (pytest.approx(0.3), 1.0, 2.0, 3.0)
    rig.run(0.01)
    settle(rig)
    after = rig.got("sim/truth")[-1]
    assert (after.x, after.y, after.theta) == (1.0, 2.0, 3.0) and after.v == 0.0  # wheels stopped
    pose = reset(rig, y=-1.0)  # unset fields keep the current pose
    assert (pose.x, pose.y, pose.theta) == (1.0, -1.0, 3.0)


def test_reset_by_selector_parameters_and_bad_request():
    rig = Rig(Sim)
    assert rig.reply(rig.query("sim/reset", params={"x": "0.5", "seed": "3"})).x == 0.5
    err = rig.reply(rig.query("sim/reset", {"x": 1.0, "sead": 3}))
    assert isinstance(err, m.ErrorReply) and err.error == "invalid_argument"


def sensor_stream(seed_at_start, reset_seed):
    rig = Rig(Sim, deployment={"seed": seed_at_start, "scenario": "harsh"})
    rig.run(0.2)
    reset(rig, x=0.4, y=0.5, theta=0.0, seed=reset_seed)
    start = len(rig.bus.published)
    for i in range(100):
        command(rig, 6.0 + (i % 7), 4.0)
        rig.run(0.01)
    out = [(k, d) for k, d in rig.bus.published[start:] if k.split("/", 2)[2] in SENSOR_TOPICS]
    unstamped = [
        (k, codec.encode(msgspec.structs.replace(codec.decode(d, m.Truth), wall=0.0)) if k.endswith("truth") else d) for k, d in out
    ]
    return unstamped  # the wall clock differs between runs


def test_reset_reseeds_so_runs_repeat():
    a = sensor_stream(1, reset_seed=42)
    b = sensor_stream(2, reset_seed=42)  # other seed before the reset: same run after it
    assert len(a) == 310 and a == b
    assert sensor_stream(1, reset_seed=43) != a


def test_encoders_wrap_from_a_large_start():
    rig = Rig(Sim, sim={"encoder_start": 2**31 - 10})
    command(rig, 10.0, -10.0)
    rig.run(0.2)
    left = [e.left for e in rig.got("sensors/encoders")]
    right = [e.right for e in rig.got("sensors/encoders")]
    assert left[0] >= 2**31 - 10 and left[-1] < 0  # wrapped past +2^31 - 1
    assert right[-1] < 2**31 - 10 and right[-1] > 0  # counting down: no wrap


@pytest.mark.parametrize(
    "payload",
    [b"\xc1", msgpack.packb({"t": 0.0, "left": "fast", "right": 1.0}), msgpack.packb({"t": 0.0, "left": math.inf, "right": 1.0})],
)
def test_bad_wheels_payload_is_counted_and_ignored(payload):
    rig = Rig(Sim)
    rig.put("motors/wheels", payload)
    rig.run(0.2)
    assert rig.svc.counters.values["bad_input"] == 1
    assert rig.got("sim/truth")[-1].v == 0.0
    command(rig, 5.0, 5.0)
    rig.run(0.2)
    assert rig.got("sim/truth")[-1].v > 0.1


def test_diag_reports_rates_and_counters():
    rig = Rig(Sim)
    rig.run(1.0)
    rig.advance(0.001)
    [diag] = rig.got("diag/sim")
    assert diag.rates["sim/truth"] == pytest.approx(100.0, rel=0.02)
    assert diag.rates["clock"] == pytest.approx(20.0, rel=0.02)
    assert diag.rates["sensors/compass"] == pytest.approx(10.0, rel=0.02)
    assert diag.counters["overruns"] == 0 and diag.counters["command_timeouts"] == 0
    assert "zenav/r1/alive/sim" in rig.bus.alive()


def test_make_clock_scales_wall_time():
    clock = Sim.make_clock(Settings.load(None, sim={"rtf": 5.0}))
    assert isinstance(clock, ScaledWallClock) and clock.rtf == 5.0
    assert clock.wall_delay(0.01) == pytest.approx(0.002)


@pytest.mark.parametrize("bad", [{"rtf": 1000.0}, {"rtf": 0.0}, {"command_timeout": 0.0}, {"speed": 1.0}, {"clock_rate_hz": 2.0}])
def test_bad_config_fails_fast(bad):
    with pytest.raises(ConfigError, match="sim"):
        Settings.load(None, sim=bad).section("sim", SimConfig)


def test_help(capsys):
    with pytest.raises(SystemExit) as e:
        main(Sim, ["--help"])
    assert e.value.code == 0 and "zenav-sim" in capsys.readouterr().out


def test_wheels_stop_at_once_when_the_motor_service_goes():
    rig = Rig(Sim)
    motor = rig.bus.token("zenav/r1/alive/motor")
    for _ in range(30):  # 0.3 s driving
        command(rig, 5.0, 5.0)
        rig.advance(0.01)
    assert rig.svc.cmd == (5.0, 5.0)
    motor.undeclare()
    rig.drain()
    assert rig.svc.cmd == (0.0, 0.0) and rig.svc.counters.values["motor_lost_stops"] == 1
    rig.close()


def test_two_robots_on_one_field_keep_out_of_each_others_body():
    rig = Rig(Sim, sim={"body_radius": 0.1})  # r1 at the origin
    r2 = Sim(Settings.load(None, deployment={"robot": "r2"}, sim={"x0": 0.5, "body_radius": 0.1}), rig.bus, rig.clock)
    r2.start()
    sims = [rig.svc, r2]

    def run(seconds: float, r1_cmd: float, r2_cmd: float = 0.0) -> None:
        for _ in range(round(seconds / 0.01)):  # both sims step on one clock, commanded at 100 Hz
            command(rig, r1_cmd, r1_cmd)
            rig.bus.publish("zenav/r2/motors/wheels", codec.encode(m.Wheels(t=0.0, left=r2_cmd, right=r2_cmd)))
            rig.clock.advance(0.01)
            for sim in sims:
                sim.drain()

    run(3.0, 5.0)  # r1 at 0.17 m/s toward r2, which stands: 0.5 m in 3 s, but 0.3 m is all there is
    bodies = [codec.decode(d, m.Body) for k, d in rig.bus.published if k == "zenav/field/sim/body"]
    assert {b.robot for b in bodies} == {"r1", "r2"} and all(b.radius == 0.1 for b in bodies)
    assert len([b for b in bodies if b.robot == "r1"]) == pytest.approx(60, abs=1)  # 20 Hz of sim time
    truth = rig.got("sim/truth")
    assert truth[-1].x == pytest.approx(0.3, abs=0.01) and abs(truth[-1].v) < 0.01  # at contact, stopped (sliding slowly round)
    ticks = rig.got("sensors/encoders")[-1].left
    assert ticks / 360 * 2 * math.pi * 0.0673 / 2 > 0.45  # its wheels turned the whole way: they slipped
    assert rig.svc.counters.values["contacts"] == 1
    assert codec.decode([d for k, d in rig.bus.published if k == "zenav/r2/sim/truth"][-1], m.Truth).x == 0.5  # not pushed

    run(1.0, 5.0, 5.0)  # r2 drives away: r1 follows, the gap it keeps no more than its 50 ms of lag
    gap = codec.decode([d for k, d in rig.bus.published if k == "zenav/r2/sim/truth"][-1], m.Truth).x - rig.got("sim/truth")[-1].x
    assert 0.2 <= gap < 0.25
    contacts = rig.svc.counters.values["contacts"]  # one more each time it caught up with r2's back

    r2.close()  # its sim stops: r1 meets its last body once more, forgets it after BODY_KEPT and drives on through
    sims.remove(r2)
    run(2.5, 5.0)
    assert rig.got("sim/truth")[-1].x > 0.7 and rig.svc.counters.values["contacts"] == contacts + 1


def test_a_sim_without_a_body_tells_the_field_nothing_and_drives_through_others():
    rig = Rig(Sim, sim={"body_radius": 0.0})
    rig.bus.publish("zenav/field/sim/body", codec.encode(m.Body(t=0.0, robot="r2", x=0.3, y=0.0, radius=0.1)))
    for _ in range(200):
        command(rig, 5.0, 5.0)
        rig.run(0.01)
    bodies = [codec.decode(d, m.Body).robot for k, d in rig.bus.published if k == "zenav/field/sim/body"]
    assert bodies == ["r2"]  # r2's only: r1 has no body to tell of
    assert rig.got("sim/truth")[-1].x > 0.3 and rig.svc.counters.values["contacts"] == 0


@pytest.mark.parametrize(
    ("sections", "stop"),
    [
        ({}, 0.92),  # the chassis's front (half its 0.16 m length) at the wall
        ({"sim": {"x0": 0.7, "body_length": 0.0, "body_width": 0.0}}, 0.9),  # the disc's: its 0.1 m radius
        ({"sim": {"x0": 0.7, "walls": False}}, None),
        ({"field": {"x_max": 1.0, "enabled": False}}, None),
    ],
    ids=["walls", "walls-disc", "walls-off", "field-off"],
)
def test_the_fields_edges_are_walls_the_robot_stops_at(sections, stop):
    base = {"sim": {"x0": 0.7}, "field": {"x_max": 1.0}}
    rig = Rig(Sim, **{name: {**base[name], **sections.get(name, {})} for name in base})
    for _ in range(300):  # 3 s at 0.17 m/s toward the edge 0.3 m ahead
        command(rig, 5.0, 5.0)
        rig.run(0.01)
    truth = rig.got("sim/truth")[-1]
    if stop is not None:  # at contact with the wall x_max = 1.0, the wheels slipping
        assert truth.x == pytest.approx(stop) and abs(truth.v) < 0.01 and rig.svc.counters.values["contacts"] == 1
        assert rig.got("sensors/encoders")[-1].left / 360 * 2 * math.pi * 0.0673 / 2 > 0.45
    else:
        assert truth.x > 1.1 and rig.svc.counters.values["contacts"] == 0


def test_a_robot_driven_into_a_wall_at_an_angle_squares_up_against_it():
    def drive(walls: bool) -> Rig:
        rig = Rig(Sim, sim={"x0": 0.7, "theta0": math.radians(12.0), "walls": walls}, field={"x_max": 1.0})
        for _ in range(400):  # 4 s toward the wall x_max = 1.0, the chassis's front-left corner first
            command(rig, 5.0, 5.0)
            rig.run(0.01)
        return rig

    def turned(rig: Rig) -> float:
        """[rad] what the gyro felt, its bias and noise included."""
        return sum(s.gyro_z for s in rig.got("sensors/imu")) * 0.01

    rig, free = drive(True), drive(False)
    truth = rig.got("sim/truth")[-1]
    # The front flat against the wall: heading square to it, the centre half the chassis's length from it.
    assert truth.theta == pytest.approx(0.0, abs=1e-9) and truth.x == pytest.approx(0.92) and abs(truth.v) < 0.01
    drift = free.got("sim/truth")[-1].theta  # without the wall: its heading, give or take the wheels' differences
    assert drift == pytest.approx(math.radians(12.0), abs=math.radians(3.0))
    # The gyro felt the wall's turn; the encoders did not: both wheels turned as far as without the wall.
    assert turned(rig) - turned(free) == pytest.approx(-drift, abs=math.radians(0.5))
    assert rig.got("sensors/encoders")[-1] == free.got("sensors/encoders")[-1]


def test_the_accelerometer_feels_the_wall_stop_the_robot_and_nothing_while_it_is_held():
    rig = Rig(Sim, sim={"x0": 0.7}, field={"x_max": 1.0}, scenario={"accel_noise": 0.0, "accel_bias": 0.0})
    for _ in range(300):  # 3 s at 0.17 m/s toward the wall 0.3 m ahead: there at about 1.3 s
        command(rig, 5.0, 5.0)
        rig.run(0.01)
    imu = [(s.t, s.accel_x) for s in rig.got("sensors/imu")]
    truth = {s.t: s.x for s in rig.got("sim/truth")}
    hit = min(t for t, _ in imu if truth.get(t, 0.0) >= 0.92 - 1e-9)  # the step the chassis met the wall
    around = [a for t, a in imu if hit - 0.02 < t <= hit + 0.02]
    assert min(around) < -5.0  # the stop: 0.17 m/s lost in a step or two
    held = [a for t, a in imu if t > hit + 0.1]
    assert len(held) > 100 and max(map(abs, held)) < 1e-9  # held still while the motors push on
    cruise = [a for t, a in imu if 0.5 < t < hit - 0.1]
    assert max(map(abs, cruise)) < 0.5  # before: what the motors gave at a steady speed


def test_a_chassis_needs_both_its_length_and_its_width():
    for sim in ({"body_length": 0.2, "body_width": 0.0}, {"body_length": 0.0}):  # the other's default is body_radius's
        with pytest.raises(Exception, match=r"body_width .* both > 0 \(a chassis against the walls\) or both 0"):
            Rig(Sim, sim=sim)


@pytest.mark.parametrize(("sim", "stop"), [({"body_radius": 0.2}, 1.0 - 0.16), ({"body_radius": 0.2, "body_length": 0.1}, 0.95)])
def test_the_default_chassis_grows_with_the_body(sim, stop):
    rig = Rig(Sim, sim={"x0": 0.5, **sim}, field={"x_max": 1.0})
    for _ in range(400):  # 4 s at 0.17 m/s toward the wall 0.5 m ahead
        command(rig, 5.0, 5.0)
        rig.run(0.01)
    assert rig.got("sim/truth")[-1].x == pytest.approx(stop)  # half its length short of the wall
