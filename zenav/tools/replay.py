"""Publish a recording back onto Zenoh, at its own pace or faster.

Messages go out in the order they were recorded, spaced as they arrived at the
recorder (log_time) divided by `rate`; rate 0 sends them as fast as the bus takes
them. Each is decoded from the recording's JSON through its contract type and
encoded as msgpack again. A replayed `clock` tick is the one thing rewritten: its
`wall` becomes the replay's wall clock and its `rtf` is multiplied by `rate` (up to
MAX_RTF, the highest a stack clock takes), so the services following it (SimClock)
extrapolate from now, not from the recording day.
A robot recorded with no `clock` (a real one, on the wall clock) gets ticks made from
its messages' stamps when `clock` is replayed: one before each message whose stamp is
TICK past the last, so services on the sim clock follow the recording all the same.
Across a longer gap in the stamps (the robot's recorder or odometry paused) they come
every FILL at most: a stack clock refuses a tick further ahead than a plausible step
([limits] clock_jump), and at rate 0 no wall time passes to make a longer one plausible.
Where the stamps go back by more than RESTART_JUMP (the robot restarted, or its wall
clock was set back), the made ticks start again from there under a new `instance`
(`replay-<n>`), as a restarted sim's would: a stack clock takes such a tick as a restart.
Recorded ticks keep the instance of the sim that sent them, so a recorded restart is one
here too; a stack clock whose own sim runs takes none of them (they are not its sim's). Only messages stamped when they were sent
make ticks: a fix is stamped at its capture (CAPTURE_STAMPED), late by design and by
however long its camera's link took, and must not take the clock back. The ticks are the
same at any rate, and so is the re-run. They stand for a clock that ticked every TICK: the
localizer holds a fix for the next odom sample HOLD plus one tick interval at most, so where
the robot's odometry paused about that long, a re-run of one whose clock ran otherwise (the
wall clock, read continuously) may apply that fix one odom sample apart from the live run.

To re-run the localizer on recorded sensors, replay `clock`, `odom`, `vps/pose` and
`sensors/imu` into a stack that runs only the localizer, and compare its `pose` with the recorded one.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Iterable

import msgspec

from zenav.common import codec, keys
from zenav.common import messages as m
from zenav.common.bus import Bus
from zenav.common.clock import MAX_RTF, RESTART_JUMP
from zenav.tools import mcap_format as fmt

TICK = 0.01  # [s] of stamps between the clock ticks made for a robot recorded without any (the sim's 100 Hz)
FILL = 0.25  # [s] of stamps at most between such ticks across a gap (well under [limits] clock_jump's default 1 s)
CAPTURE_STAMPED = frozenset({"vps/pose", "localizer/fixes"})  # stamped at a capture, not when sent: no tick made from them


def replay(
    path: str,
    bus: Bus,
    rate: float = 1.0,
    robot: str | None = None,
    as_robot: str | None = None,
    suffixes: Iterable[str] | None = None,
    stop: threading.Event | None = None,
) -> int:
    """Publish the recording's messages (of `robot`, on `suffixes`; all by default); return how many.

    `as_robot` publishes under another robot id than the recorded one; `stop` ends early.
    """
    if rate < 0:
        raise ValueError(f"rate must be >= 0, not {rate}")
    stop = stop or threading.Event()
    suffixes = None if suffixes is None else list(suffixes)  # read twice: for the clock, then the messages
    start_wall = time.monotonic()
    first_ns: int | None = None
    sent = 0
    ticks: dict[str, float] = {}  # robot recorded without a clock -> the last tick made for it
    timelines: dict[str, int] = {}  # robot recorded without a clock -> its made ticks' timeline (one more at each restart)
    made_rtf = replayed_rtf(1.0, rate)  # a robot recorded without a clock ran in realtime
    if suffixes is None or "clock" in suffixes:
        ticks = {r: -math.inf for r, topics in fmt.topics(path).items() if "clock" not in topics and robot in (None, r)}
    for rec in fmt.read(path, robot, suffixes):
        first_ns = rec.log_time if first_ns is None else first_ns
        if rate > 0:
            due = start_wall + (rec.log_time - first_ns) / fmt.NS / rate
            if stop.wait(max(due - time.monotonic(), 0.0)):  # pacing: waits until the message is due
                break
        elif stop.is_set():
            break
        msg, on = rec.msg, as_robot or rec.robot
        if isinstance(msg, m.Clock):
            msg = msgspec.structs.replace(msg, wall=time.time(), rtf=replayed_rtf(msg.rtf, rate))
        elif (
            rec.robot in ticks
            and rec.suffix not in CAPTURE_STAMPED
            and not ticks[rec.robot] - RESTART_JUMP <= msg.t < ticks[rec.robot] + TICK
        ):
            if msg.t < ticks[rec.robot]:
                timelines[rec.robot] = timelines.get(rec.robot, 0) + 1
            instance = f"replay-{timelines.get(rec.robot, 0)}"
            for t in made_ticks(ticks[rec.robot], msg.t):
                bus.publish(keys.key(on, "clock"), codec.encode(m.Clock(t=t, rtf=made_rtf, wall=time.time(), instance=instance)))
            ticks[rec.robot] = msg.t
        bus.publish(keys.key(on, rec.suffix), codec.encode(msg))
        sent += 1
    return sent


def replayed_rtf(rtf: float, rate: float) -> float:
    """A recorded tick's rtf replayed at `rate`: times the rate, at most MAX_RTF; as recorded at rate 0."""
    return min(rtf * rate, MAX_RTF) if rate > 0 else rtf


def made_ticks(last: float, t: float) -> list[float]:
    """The ticks made up to a stamp t, the last one made at `last` (-inf: none yet): t, after
    evenly spaced ones across a gap longer than FILL; t alone where the stamps went back."""
    n = 1 if math.isinf(last) or t < last else math.ceil((t - last) / FILL)
    return [t] if n <= 1 else [last + (t - last) * k / n for k in range(1, n)] + [t]
