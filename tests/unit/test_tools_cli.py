"""record, replay and plot on the in-memory bus, and the commands' argument handling."""

from __future__ import annotations

import argparse
import math
import threading
import time

import pytest
from mcap.writer import Writer

from zenav.cli import plot as plot_cmd
from zenav.cli import replay as replay_cmd
from zenav.cli.main import EXIT_FAILED, EXIT_OK, EXIT_USAGE, build_parser
from zenav.common import codec, keys
from zenav.common import messages as m
from zenav.common.bus import MemoryBus
from zenav.common.clock import ACCEPTED, MAX_RTF, RESTARTED, SimClock
from zenav.tools import mcap_format as fmt
from zenav.tools.record import Recorder
from zenav.tools.replay import FILL, replay


def parse(*argv: str) -> argparse.Namespace:
    return build_parser().parse_args(argv)


def write_recording(path: str, messages: list[tuple[str, m.Topic, float]]) -> None:
    """A recording with chosen arrival times: (key, message, log time [s])."""
    w = Writer(path)
    w.start()
    channels: dict[str, int] = {}
    for key, msg, log_s in messages:
        if key not in channels:
            typ = type(msg)
            schema = w.register_schema(fmt.schema_name(typ), fmt.SCHEMA_ENCODING, fmt.schema_bytes(typ))
            channels[key] = w.register_channel(fmt.topic_of(key), fmt.MESSAGE_ENCODING, schema)
        w.add_message(channels[key], log_time=fmt.stamp(log_s), data=fmt.to_json(msg), publish_time=fmt.stamp(msg.t))
    w.finish()


def test_the_commands_parse():
    args = parse("record", "out.mcap", "--robot", "r2", "--duration", "5")
    assert (args.out, args.robot, args.duration, args.all) == ("out.mcap", "r2", 5.0, False)
    args = parse("replay", "in.mcap", "--rate", "4", "--topics", "clock,odom")
    assert (args.input, args.rate, args.topics, args.from_robot) == ("in.mcap", 4.0, "clock,odom", None)
    args = parse("view", "--port", "9000")
    assert (args.host, args.port) == (None, 9000)  # unset: the view's own default (127.0.0.1)
    args = parse("plot", "in.mcap", "-o", "out.png")
    assert (args.input, args.out) == ("in.mcap", "out.png")


def test_replay_refuses_bad_arguments_before_connecting(tmp_path, capsys):
    missing = str(tmp_path / "none.mcap")
    assert replay_cmd.run(parse("replay", missing, "--topics", "odom,odmo")) == EXIT_USAGE
    assert "odmo" in capsys.readouterr().err
    assert replay_cmd.run(parse("replay", missing, "--rate", "-1")) == EXIT_USAGE
    assert replay_cmd.run(parse("replay", missing)) == EXIT_USAGE


def test_replay_refuses_a_robot_the_recording_does_not_hold_and_several_published_as_one(tmp_path, capsys, monkeypatch):
    path = str(tmp_path / "two.mcap")
    write_recording(path, [(keys.key(r, "odom"), m.Odom(t=1.0, x=0.0, y=0.0, theta=0.0, v=0.0, omega=0.0), 0.0) for r in ("r1", "r2")])
    monkeypatch.setattr(replay_cmd, "open_bus", lambda args: pytest.fail("connected"))
    assert replay_cmd.run(parse("replay", path, "--from-robot", "r3")) == EXIT_USAGE
    assert "holds no robot r3 (it holds r1, r2)" in capsys.readouterr().err
    assert replay_cmd.run(parse("replay", path, "--robot", "r9")) == EXIT_USAGE
    assert "holds robots r1, r2: --robot (or ZENAV_ROBOT) r9 would publish them all as one" in capsys.readouterr().err
    monkeypatch.setenv("ZENAV_ROBOT", "r9")
    assert replay_cmd.run(parse("replay", path)) == EXIT_USAGE  # the same from the environment
    monkeypatch.setattr(replay_cmd, "open_bus", lambda args: MemoryBus())
    assert replay_cmd.run(parse("replay", path, "--from-robot", "r2", "--rate", "0")) == EXIT_OK  # one of them, as r9
    assert "1 messages replayed" in capsys.readouterr().err


def test_record_on_the_memory_bus_then_plot(tmp_path, capsys):
    bus = MemoryBus()
    path = str(tmp_path / "run.mcap")
    rec = Recorder(path, bus, "r1").start()
    for i in range(200):
        t, x = i * 0.01, i * 0.005
        bus.publish(keys.key("r1", "sim/truth"), codec.encode(m.Truth(t=t, x=x, y=0.0, theta=0.0, v=0.5, omega=0.0)))
        bus.publish(keys.key("r1", "odom"), codec.encode(m.Odom(t=t, x=x * 1.1, y=0.0, theta=0.0, v=0.5, omega=0.0)))
        bus.publish(keys.key("r1", "pose"), codec.encode(m.Pose(t=t, x=x, y=0.01, theta=0.0, v=0.5, omega=0.0)))
        if i % 10 == 0:
            bus.publish(keys.key("r1", "vps/pose"), codec.encode(m.VpsPose(t=t, x=x, y=-0.02, theta=0.0)))
    bus.publish(keys.key("r2", "odom"), codec.encode(m.Odom(t=0.0, x=0, y=0, theta=0, v=0, omega=0)))  # not this robot
    rec.stop()
    assert rec.counts == {"zenav/r1/sim/truth": 200, "zenav/r1/odom": 200, "zenav/r1/pose": 200, "zenav/r1/vps/pose": 20}
    assert rec.dropped == 0 and rec.duration >= 0.0

    out = tmp_path / "run.png"
    assert plot_cmd.run(parse("plot", path, "-o", str(out))) == EXIT_OK
    assert out.read_bytes()[:4] == b"\x89PNG"
    report = capsys.readouterr().out
    assert "pose   rms   1.00 cm" in report and "fixes  rms   2.00 cm" in report


def test_plot_fails_cleanly_without_zenav_topics(tmp_path, capsys):
    path = str(tmp_path / "empty.mcap")
    write_recording(path, [])
    assert plot_cmd.run(parse("plot", path, "-o", str(tmp_path / "x.png"))) == EXIT_FAILED
    assert "no zenav topics" in capsys.readouterr().err
    assert plot_cmd.run(parse("plot", str(tmp_path / "none.mcap"), "-o", str(tmp_path / "x.png"))) == EXIT_USAGE


def clock_recording(path: str) -> None:
    write_recording(path, [(keys.key("r1", "clock"), m.Clock(t=i * 1.0, rtf=2.0, wall=5.0), 100.0 + i * 0.2) for i in range(3)])


def replayed_into_a_clock(path: str, rate: float = 0.0) -> tuple[int, list[float], list[str], SimClock]:
    """Replay a recording with a stack clock following r1's ticks: (messages sent, the ticks, the clock's outcome
    for each, the clock)."""
    clock, outcomes, ticks = SimClock(), [], []

    def follow(key: str, data: bytes) -> None:
        tick = codec.decode(data, m.Clock)
        ticks.append(tick.t)
        outcomes.append(clock.update(tick))

    bus = MemoryBus()
    bus.subscribe(keys.key("r1", "clock"), follow)
    return replay(path, bus, rate=rate), ticks, outcomes, clock


def test_replay_keeps_the_recorded_pace_divided_by_the_rate(tmp_path):
    path = str(tmp_path / "clock.mcap")
    clock_recording(path)
    bus = MemoryBus()
    start = time.monotonic()
    assert replay(path, bus, rate=2.0) == 3
    assert time.monotonic() - start >= 0.2  # 0.4 s recorded, twice as fast
    clocks = [codec.decode(d, m.Clock) for _, d in bus.published]
    assert [c.t for c in clocks] == [0.0, 1.0, 2.0]
    assert all(c.rtf == 4.0 and c.wall > 1e9 for c in clocks)  # rtf times the rate; the replay's wall clock
    bus = MemoryBus()
    assert replay(path, bus, rate=80.0) == 3
    assert [codec.decode(d, m.Clock).rtf for _, d in bus.published] == [MAX_RTF] * 3  # 160x: as high as a stack clock takes


def test_a_robot_recorded_without_a_clock_gets_ticks_from_its_stamps(tmp_path):
    path = str(tmp_path / "robot.mcap")
    t0 = 1.8e9  # a real robot's wall clock
    rows: list[tuple[str, m.Topic, float]] = []
    for i in range(40):
        t = t0 + i * 0.005
        rows.append((keys.key("r1", "odom"), m.Odom(t=t, x=0.0, y=0.0, theta=0.0, v=0.0, omega=0.0), i * 0.001))
        if i % 10 == 9:
            rows.append((keys.key("r1", "vps/pose"), m.VpsPose(t=t - 0.3, x=0.0, y=0.0, theta=0.0), i * 0.001))
    rows.append((keys.key("r2", "clock"), m.Clock(t=5.0), 0.05))  # another robot, with its own clock: none made
    rows.append((keys.key("r2", "odom"), m.Odom(t=5.0, x=0.0, y=0.0, theta=0.0, v=0.0, omega=0.0), 0.05))
    write_recording(path, rows)
    bus = MemoryBus()
    assert replay(path, bus, rate=0.0) == 46
    out = [(k.split("/", 2)[1:], codec.decode(d, keys.TOPICS[k.split("/", 2)[2]])) for k, d in bus.published]
    ticks = [msg for (r, s), msg in out if (r, s) == ("r1", "clock")]
    assert [c.t for c in ticks] == [t0 + i * 0.01 for i in range(20)]  # one per TICK of stamps, the fixes' not ahead
    assert all(c.rtf == 1.0 and c.wall > 1e9 for c in ticks)
    last = -math.inf
    for (r, s), msg in out:  # each tick before the first odom sample it covers; none behind
        if (r, s) == ("r1", "clock"):
            last = msg.t
        elif (r, s) == ("r1", "odom"):
            assert last <= msg.t < last + 0.01
    assert [msg.t for (r, s), msg in out if r == "r2"] == [5.0, 5.0]  # its recorded clock only
    bus = MemoryBus()
    assert replay(path, bus, rate=0.0, suffixes=["odom", "vps/pose"]) == 45  # clock not asked for: none made
    assert not [k for k, _ in bus.published if k.endswith("/clock")]


def test_a_stack_clock_takes_every_tick_made_across_a_gap_in_the_stamps_even_as_fast_as_possible(tmp_path):
    path = str(tmp_path / "paused.mcap")
    t0 = 1.8e9
    stamps = [t0 + i * 0.01 for i in range(50)] + [t0 + 5.49 + i * 0.01 for i in range(50)]  # the robot paused 5 s
    write_recording(path, [(keys.key("r1", "odom"), m.Odom(t=t, x=0.0, y=0.0, theta=0.0, v=0.0, omega=0.0), t - t0) for t in stamps])
    for rate in (0.0, 1000.0):  # no wall time for the gap, and a little
        sent, ticks, outcomes, clock = replayed_into_a_clock(path, rate)
        assert sent == 100
        assert set(outcomes) == {ACCEPTED} and clock.tick() == stamps[-1]
        gaps = [b - a for a, b in zip(ticks, ticks[1:])]
        assert min(gaps) > 0.0 and max(gaps) <= FILL + 1e-9
        assert ticks[:50] == stamps[:50] and ticks[-50:] == stamps[-50:]  # the stamps' own ticks, as without a gap


def test_ticks_made_from_stamps_start_again_where_the_robot_restarted(tmp_path):
    path = str(tmp_path / "restarted.mcap")
    t0 = 1.8e9
    before = [t0 + i * 0.01 for i in range(30)]
    after = [3.0 + i * 0.01 for i in range(30)]  # the robot restarted: its stamps from its boot
    odom = [m.Odom(t=t, x=0.0, y=0.0, theta=0.0, v=0.0, omega=0.0) for t in before + after]
    rows: list[tuple[str, m.Topic, float]] = [(keys.key("r1", "odom"), msg, i * 0.01) for i, msg in enumerate(odom)]
    fix = m.VpsPose(t=after[9] - 0.3, x=0.0, y=0.0, theta=0.0)  # late: no tick back for it
    rows.insert(40, (keys.key("r1", "vps/pose"), fix, 0.395))
    write_recording(path, rows)
    sent, ticks, outcomes, clock = replayed_into_a_clock(path)
    assert sent == 61
    assert ticks == before + after  # one a stamp (TICK apart), from the restart on too
    assert outcomes == [ACCEPTED] * 30 + [RESTARTED] + [ACCEPTED] * 29 and clock.tick() == after[-1]


def test_a_fix_that_came_very_late_takes_the_made_ticks_back_not_at_all(tmp_path):
    path = str(tmp_path / "slow_camera.mcap")
    t0 = 1.8e9
    stamps = [t0 + i * 0.01 for i in range(300)]
    rows: list[tuple[str, m.Topic, float]] = [
        (keys.key("r1", "odom"), m.Odom(t=t, x=0.0, y=0.0, theta=0.0, v=0.0, omega=0.0), t - t0) for t in stamps
    ]
    # A camera whose link stalled: its fix comes 1.5 s after its capture, more than a restart's jump back.
    fix = m.VpsPose(t=stamps[200] - 1.5, x=0.0, y=0.0, theta=0.0)
    audit = m.Fix(
        t=fix.t,
        t_arrival=stamps[200],
        latency=1.5,
        replay_depth=0,
        innovation=(0.0, 0.0, 0.0),
        mahalanobis_d2=0.0,
        accepted=False,
        reason="too_old",
    )
    rows[201:201] = [(keys.key("r1", "vps/pose"), fix, 2.0), (keys.key("r1", "localizer/fixes"), audit, 2.0)]
    write_recording(path, rows)
    sent, ticks, outcomes, _ = replayed_into_a_clock(path)
    assert sent == 302
    assert ticks == stamps  # the odometry's stamps only: the fixes, stamped at their capture, make none
    assert set(outcomes) == {ACCEPTED}  # no restart, so a localizer re-run on it keeps its estimate


def test_replay_stops_when_told(tmp_path):
    path = str(tmp_path / "clock.mcap")
    clock_recording(path)
    stop = threading.Event()
    stop.set()
    assert replay(path, MemoryBus(), rate=1.0, stop=stop) == 0
    with pytest.raises(ValueError):
        replay(path, MemoryBus(), rate=-1.0)


def test_recording_every_robot(tmp_path):
    bus = MemoryBus()
    path = str(tmp_path / "all.mcap")
    rec = Recorder(path, bus, None).start()
    for robot in ("r2", "r1"):
        bus.publish(keys.key(robot, "odom"), codec.encode(m.Odom(t=1.0, x=0, y=0, theta=0, v=0, omega=0)))
    bus.publish("other/r1/odom", codec.encode(m.Odom(t=1.0, x=0, y=0, theta=0, v=0, omega=0)))
    rec.stop()
    assert rec.keyexpr == "zenav/*/**" and set(rec.counts) == {"zenav/r1/odom", "zenav/r2/odom"}
    assert fmt.robots(path) == ["r2", "r1"]
    assert [r.key for r in fmt.read(path, robot="r1")] == ["zenav/r1/odom"]
