"""`zenav record` and `zenav replay` on a real router: every topic and field, Ctrl-C, re-running the localizer."""

from __future__ import annotations

import json
import math
import queue
import signal
import subprocess
import sys
import time

import msgspec
from mcap.reader import make_reader

from tests.support.matching import wait_subscriber
from tests.support.procs import reaped, stderr_lines
from zenav.common import codec, keys
from zenav.common import messages as m
from zenav.common.bus import MemoryBus, ZenohBus
from zenav.tools import mcap_format as fmt
from zenav.tools.record import Recorder
from zenav.tools.replay import TICK, replay

COV = tuple(float(i) / 100 for i in range(9))

# One message of every contract topic, every field set away from its default.
EXAMPLES: dict[str, m.Topic] = {
    "clock": m.Clock(t=1.5, rtf=2.0, wall=1.7e9),
    "sim/truth": m.Truth(t=1.5, x=0.1, y=0.2, theta=0.3, v=0.4, omega=0.5),
    "sensors/encoders": m.Encoders(t=1.5, left=-(2**31), right=2**31 - 1),
    "sensors/imu": m.Imu(t=1.5, gyro_z=0.01, accel_x=0.02, accel_y=-0.03),
    "sensors/compass": m.Compass(t=1.5, heading=-3.1),
    "vps/pose": m.VpsPose(t=1.2, x=0.11, y=0.21, theta=0.31, cov=COV),
    "odom": m.Odom(t=1.5, x=0.12, y=0.22, theta=0.32, v=0.2, omega=0.1, cov=COV, frame="odom"),
    "pose": m.Pose(t=1.5, x=0.1, y=0.2, theta=0.3, v=0.2, omega=0.1, cov=COV, correction=(0.01, -0.02, 0.003), calibration={"scale": 1.01}),
    "cmd_vel": m.CmdVel(t=1.5, v=0.2, omega=-0.4),
    "motors/wheels": m.Wheels(t=1.5, left=5.5, right=6.5),
    "nav/state": m.NavState(
        t=1.5,
        state="FOLLOWING_PATH",
        goal_id=3,
        goal={"type": "follow_path", "points": [[1.0, 0.0], [1.0, 1.0]]},
        result=None,
        distance_remaining=1.4,
        heading_error=0.05,
        eta=7.0,
        elapsed=2.5,
        next_point=1,
        cross_track_error=0.01,
        message="ok",
    ),
    "localizer/fixes": m.Fix(
        t=1.2,
        t_arrival=1.5,
        latency=0.3,
        replay_depth=30,
        innovation=(0.01, 0.02, 0.003),
        mahalanobis_d2=1.2,
        accepted=False,
        reason="gate",
    ),
    **{
        f"diag/{s}": m.Diag(t=1.5, service=s, uptime=3.0, counters={"msgs_in": 7}, rates={"odom": 100.0}, status="degraded", message="x")
        for s in keys.SERVICES
    },
}


def test_every_topic_and_field_is_recorded_with_a_schema(router, publisher, tmp_path):
    path = str(tmp_path / "run.mcap")
    started = time.time_ns()
    rec_bus = ZenohBus.open(router)
    rec = Recorder(path, rec_bus, "r1").start()
    try:
        wait_subscriber(publisher, keys.key("r1", "clock"))
        for suffix, msg in EXAMPLES.items():
            publisher.publish(keys.key("r1", suffix), codec.encode(msg))
        publisher.publish(keys.key("r1", "odom"), b"\xc1 not msgpack")  # bad payload: skipped
        publisher.publish(keys.key("r1", "not/a/topic"), codec.encode({"t": 1.0}))  # no contract topic: skipped
        publisher.publish(keys.key("r2", "odom"), codec.encode(EXAMPLES["odom"]))  # another robot: not subscribed
        publisher.publish(keys.key("r1", "clock"), codec.encode(m.Clock(t=9.0)))  # the tail
    finally:
        rec.stop()
        rec_bus.close()

    assert rec.skipped == {keys.key("r1", "odom"): 1, keys.key("r1", "not/a/topic"): 1}
    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None
        contract = [c.topic for c in summary.channels.values() if "/viz/" not in c.topic]  # the rest: tools/scene.py's
        assert (
            sum(summary.statistics.channel_message_counts[c.id] for c in summary.channels.values() if c.topic in contract)
            == len(EXAMPLES) + 1
        )
        by_topic: dict[str, list] = {}
        for schema, channel, message in reader.iter_messages(topics=contract):
            by_topic.setdefault(channel.topic, []).append((schema, channel, message))
    assert set(by_topic) == {f"/zenav/r1/{s}" for s in EXAMPLES}
    for suffix, msg in EXAMPLES.items():
        entries = by_topic[f"/zenav/r1/{suffix}"]
        schema, channel, message = entries[0]
        typ = keys.TOPICS[suffix]
        assert channel.message_encoding == "json"
        assert (schema.name, schema.encoding) == (f"zenav.{typ.__name__}", "jsonschema")
        js = json.loads(schema.data)
        assert js["type"] == "object" and set(js["properties"]) == set(typ.__struct_fields__)
        data = json.loads(message.data)
        assert set(data) == set(typ.__struct_fields__)  # every field, as JSON
        assert msgspec.convert(data, typ) == msg
        assert message.publish_time == round(msg.t * 1e9)
        assert started <= message.log_time <= time.time_ns()  # the recorder's wall clock
    assert json.loads(by_topic["/zenav/r1/clock"][-1][2].data)["t"] == 9.0
    # one schema per message type, shared by the six diag channels
    assert len([s for s in summary.schemas.values() if s.encoding == "jsonschema"]) == len({type(msg) for msg in EXAMPLES.values()})


def test_ctrl_c_finishes_the_file_with_the_last_messages(router, publisher, tmp_path):
    path = tmp_path / "sigint.mcap"
    proc = subprocess.Popen(
        [sys.executable, "-m", "zenav", "record", str(path), "--connect", router],
        stderr=subprocess.PIPE,
        text=True,
    )
    lines = stderr_lines(proc)
    with reaped(proc):
        assert "recording zenav/r1/**" in lines.get(timeout=30)
        wait_subscriber(publisher, keys.key("r1", "clock"))
        sent = [m.Clock(t=i * 0.01) for i in range(1, 501)]
        for msg in sent:
            publisher.publish(keys.key("r1", "clock"), codec.encode(msg))
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=30) == 0
    assert "500 messages on 1 topics" in lines.get(timeout=10)
    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()  # None if the file was not finished
        got = [json.loads(msg.data)["t"] for _, _, msg in reader.iter_messages(topics=["/zenav/r1/clock"])]
    assert summary is not None
    [clock] = [c.id for c in summary.channels.values() if c.topic == "/zenav/r1/clock"]
    assert summary.statistics.channel_message_counts[clock] == len(got)
    assert got == [msg.t for msg in sent]  # all of them, in order, the last one included


def test_replay_publishes_the_recording_again(router, publisher, tmp_path):
    path = str(tmp_path / "run.mcap")
    rec_bus = ZenohBus.open(router)
    rec = Recorder(path, rec_bus, "r1").start()
    try:
        wait_subscriber(publisher, keys.key("r1", "odom"))
        for i in range(50):
            publisher.publish(keys.key("r1", "clock"), codec.encode(m.Clock(t=i * 0.01, rtf=2.0, wall=1.0)))
            publisher.publish(keys.key("r1", "odom"), codec.encode(m.Odom(t=i * 0.01, x=i * 0.001, y=0.0, theta=0.0, v=0.1, omega=0.0)))
    finally:
        rec.stop()
        rec_bus.close()

    got: queue.Queue = queue.Queue()
    sub_bus = ZenohBus.open(router)
    sub_bus.subscribe("zenav/r7/**", lambda key, data: got.put((key, data)))
    try:
        wait_subscriber(publisher, keys.key("r7", "odom"))
        sent = replay(path, publisher, rate=0.0, as_robot="r7", suffixes=["clock", "odom"])
        assert sent == 100
        out = [got.get(timeout=10) for _ in range(sent)]
    finally:
        sub_bus.close()
    odoms = [codec.decode(d, m.Odom) for k, d in out if k == "zenav/r7/odom"]
    clocks = [codec.decode(d, m.Clock) for k, d in out if k == "zenav/r7/clock"]
    assert [o.x for o in odoms] == [i * 0.001 for i in range(50)]
    assert [c.t for c in clocks] == [i * 0.01 for i in range(50)]
    assert all(c.wall > 1e9 and c.rtf == 2.0 for c in clocks)  # the replay's wall clock, not the recorded one


LOCALIZER_INPUTS = ["clock", "odom", "vps/pose", "sensors/imu", "sensors/compass"]


def drive_arc(client, seconds: float) -> None:
    """Command the sim's wheels directly (no motor, no navigator) for `seconds` of sim time."""
    truth = client.latest("sim/truth")
    t0 = truth.wait(timeout=20).t
    t = t0
    while t < t0 + seconds:
        client.publish("motors/wheels", m.Wheels(t=t, left=8.0, right=10.0))
        t = truth.wait(lambda msg, t=t: msg.t >= t + 0.1, timeout=10).t
    client.publish("motors/wheels", m.Wheels(t=t, left=0.0, right=0.0))


def test_replay_reruns_the_localizer_on_recorded_sensors(router, make_stack, client, publisher, tmp_path):
    path = str(tmp_path / "run.mcap")
    rec_bus = ZenohBus.open(router)
    rec = Recorder(path, rec_bus, "r1").start()  # before the stack: the recording holds every message
    try:
        # The sim's clock ticks every TICK, as the ticks the replay makes for a recording without
        # one: stripped of it below, the recording re-runs on the clock it ran on. (A slower clock
        # would hold a fix longer for its odom sample, HOLD plus one tick interval: where the
        # odometry paused in between, the made ticks would release it one sample earlier.)
        first = make_stack(["localizer", "odometry", "vps", "sim"], sim={"rtf": 2.0, "clock_rate_hz": 1.0 / TICK})
        client.wait_alive(["localizer", "odometry", "vps", "sim"], timeout=30)
        drive_arc(client, 5.0)
        client.latest("localizer/fixes").wait(timeout=10)
        first.stop()
    finally:
        rec.stop()
        rec_bus.close()
    recorded = {r.msg.t: r.msg for r in fmt.read(path, "r1", ["pose"])}
    assert len(recorded) > 400 and sum(r.msg.accepted for r in fmt.read(path, "r1", ["localizer/fixes"])) > 25

    poses: queue.Queue = queue.Queue()
    client.subscribe("pose", poses.put)
    fixes: queue.Queue = queue.Queue()
    client.subscribe("localizer/fixes", fixes.put)

    class Stalling:
        """The publisher, stalled once after the 15th fix as a busy host stalls a replay (longer than HOLD)."""

        fixes = 0

        def publish(self, key: str, data: bytes) -> None:
            publisher.publish(key, data)
            if key.endswith("/vps/pose"):
                self.fixes += 1
                if self.fixes == 15:
                    time.sleep(0.1)

    def rerun(rate: float, bus, source: str = path) -> dict[float, m.Pose]:
        """Replay the localizer's inputs (`clock` too) into a fresh localizer; return its poses by t."""
        stack = make_stack(["localizer"])
        client.wait_alive(["localizer"], timeout=30)
        for _ in range(poses.qsize()):  # poses the last rerun made past the recorded ones (the recorded odom outlasts its poses)
            poses.get_nowait()
        for _ in range(fixes.qsize()):
            fixes.get_nowait()
        wait_subscriber(publisher, keys.key("r1", "odom"))
        assert replay(source, bus, rate=rate, suffixes=LOCALIZER_INPUTS) > 1000
        out: dict[float, m.Pose] = {}
        while len(out) < len(recorded):
            try:
                p = poses.get(timeout=5)
            except queue.Empty:
                break
            out[p.t] = p
        counters = stack.services["localizer"].counters.values
        stack.stop()
        # The replay's clock, recorded or made from the stamps, never goes back: a restart would throw the estimate away.
        assert counters.get("clock_resets", 0) == 0, f"the replayed clock restarted {counters['clock_resets']} times"
        return out

    at_pace, faster = rerun(1.0, publisher), rerun(4.0, Stalling())
    # The replay is deterministic: at its own pace or four times faster and stalled, the same poses.
    assert len(at_pace) >= 0.99 * len(recorded)
    assert at_pace == faster
    # It reproduces the recorded run. A fix that reached the original localizer one odom
    # sample earlier or later than it reached the recorder shifts a few poses slightly.
    reproduces(recorded, at_pace)

    # A robot on the wall clock records no `clock`: the replay makes the ticks from the stamps,
    # and the localizer (on the sim clock, as `zenav up --services localizer` runs it) follows.
    unclocked = str(tmp_path / "no_clock.mcap")
    mem = MemoryBus()
    copier = Recorder(unclocked, mem, "r1").start()
    replay(path, mem, rate=4.0, suffixes=[s for s in LOCALIZER_INPUTS if s != "clock"])
    copier.stop()
    assert "clock" not in fmt.topics(unclocked)["r1"]
    again = rerun(1.0, publisher, unclocked)
    assert len(again) >= 0.99 * len(recorded)
    reproduces(recorded, again)
    audits = [fixes.get_nowait() for _ in range(fixes.qsize())]
    assert sum(f.accepted for f in audits) > 25
    assert rerun(0.0, publisher, unclocked) == again  # its ticks are the same as fast as possible
    # Their arrival is on the recording's time: each fix as late as in the recorded run (the VPS's ~0.3 s).
    late = {r.msg.t: r.msg.latency for r in fmt.read(path, "r1", ["localizer/fixes"])}
    off = sorted(abs(f.latency - late[f.t]) for f in audits if f.accepted and f.t in late)
    assert len(off) > 25 and off[len(off) // 2] < 0.02 and all(f.latency > 0.0 for f in audits if f.accepted)


def reproduces(recorded: dict[float, m.Pose], rerun: dict[float, m.Pose]) -> None:
    """Most poses of a re-run are the recorded ones, and the rest within millimetres."""
    diffs = [math.hypot(recorded[t].x - p.x, recorded[t].y - p.y) for t, p in rerun.items() if t in recorded]
    same = sum(d < 1e-6 for d in diffs)
    assert same >= 0.9 * len(diffs), f"{same} of {len(diffs)} poses reproduced"
    assert math.sqrt(sum(d * d for d in diffs) / len(diffs)) < 0.005  # [m] rms
