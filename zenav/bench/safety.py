"""Safety figures measured on real processes: a frozen operator, a stop under a flood, bad inputs.

    zenav bench safety               # each figure once
    zenav bench safety --floods 30   # and the stop under a flood 30 times (spread)

A router and the whole stack run as processes (their logs in a temporary folder);
the operator and the flood are child processes too (bench/safety_rig.py); the bad
inputs are sent from this one. Times are wall seconds (CLOCK_MONOTONIC, shared by
the processes).
"""

from __future__ import annotations

import json
import math
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import zenoh

from zenav.bench import child
from zenav.bench.safety_rig import OPERATOR_GOAL, WAIT, StackRig, big, end_child, flood, operator, read_lines, start_child
from zenav.common import codec
from zenav.common import messages as m
from zenav.common.contract import State

FLOOD_GOALS, FLOOD_POINTS = 30, 10_000  # follow_path goals the flood sends at once, points in each
BIG_PARAMS = 200_000  # [bytes] selector parameter: over [limits] max_params, under the router's largest message
OVER_PAYLOAD = 2**20 + 1  # [bytes] one over [limits] max_payload, under the router's largest message
BIG_PAYLOAD = 100 * 2**20  # [bytes] over the router's largest message: dropped there
GAP_BEFORE, GAP_AFTER = 0.5, 3.0  # [s] window of pose arrivals around a bad input


def _zero(t: float, after: float, v: float, w: float) -> bool:
    return t >= after and v == 0.0 and w == 0.0


@dataclass
class Freeze:
    """A frozen operator: SIGSTOP mid-goal to zero cmd_vel / zero wheels [s], and how the goal ended."""

    cmd_vel: float
    wheels: float
    message: str


def frozen_operator(rig: StackRig, cli: bool = False) -> Freeze:
    """An operator process holding a Robot (or `zenav goto --wait`) sends a goal, is frozen (SIGSTOP) once the robot moves."""
    rig.ready()
    last = rig.nav.wait(timeout=WAIT).goal_id
    x, y = OPERATOR_GOAL
    argv = (
        [sys.executable, "-m", "zenav", "goto", str(x), str(y), "--wait", "--connect", rig.endpoint]
        if cli
        else child.argv(operator, rig.endpoint)
    )
    proc = subprocess.Popen(argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    read_lines(proc)
    try:
        goal = rig.nav.wait(lambda s: s.goal_id > last and s.state != State.STOPPED, timeout=90).goal_id
        rig.truth.wait(lambda t: abs(t.v) > 0.1, timeout=WAIT)
        t0 = time.monotonic()
        os.kill(proc.pid, signal.SIGSTOP)
        cmd = rig.cmd.first(lambda t, c: _zero(t, t0, c.v, c.omega))
        wheels = rig.wheels.first(lambda t, w: _zero(t, t0, w.left, w.right))
        st = rig.nav.wait(lambda s: s.goal_id == goal and s.result is not None, timeout=WAIT)
        return Freeze(cmd - t0, wheels - t0, f"{st.result}: {st.message}")
    finally:
        end_child(proc)


@dataclass
class Flood:
    """nav/stop sent right after a flood of follow_path goals."""

    answered: float  # [s] stop sent -> answered
    zero: float  # [s] stop sent -> first zero cmd_vel
    goals: int  # flood goals sent before the stop
    after: int  # of those, answered after the stop was


def stop_under_flood(rig: StackRig, goals: int = FLOOD_GOALS, points: int = FLOOD_POINTS) -> Flood:
    """A second process sends `goals` follow_path goals of `points` points at once; then nav/stop."""
    rig.ready()
    proc, lines = start_child(flood, rig.endpoint, goals, points)
    try:
        assert lines.get(timeout=60).startswith("sent")
        t0 = time.monotonic()
        rig.client.query("nav/stop", timeout=WAIT)
        answered = time.monotonic()
        zero = rig.cmd.first(lambda t, c: _zero(t, t0, c.v, c.omega))
        times = [t for t, _ in json.loads(lines.get(timeout=60))]
    finally:
        end_child(proc)
    rig.client.query("nav/stop", timeout=WAIT)  # the newest flood goal ran after the stop
    return Flood(answered - t0, zero - t0, goals, sum(t > answered for t in times))


BURST_GOALS = 60  # follow_path goals of FLOOD_POINTS points in the burst a stop must void
BURST_AFTER = 1.0  # [s] after the burst's last answer, cmd_vel is still watched (a goal started late drives then)


@dataclass
class Burst:
    """nav/stop once a burst of follow_path goals from another process has reached the navigator."""

    goals: int  # goals in the burst, all sent (and arrived) before the stop
    replies: int  # goals answered (every one is: started, or voided)
    queued: int  # of those, answered after the stop was sent (still at the navigator when it came)
    voided: int  # answered unavailable, voided by the stop
    started: int  # answered ok after the stop's answer: started after it
    moving: int  # cmd_vel messages other than zero from the stop's answer to BURST_AFTER after the burst's last answer
    answered: float  # [s] stop sent -> answered


def stop_after_a_burst(rig: StackRig, goals: int = BURST_GOALS, points: int = FLOOD_POINTS) -> Burst:
    """A second process sends `goals` follow_path goals of `points` points at once; once they have all reached the
    navigator (safety_rig's `burst`), nav/stop; then what started, and what was commanded, for the rest of the burst."""
    rig.ready()
    proc, lines = start_child(flood, rig.endpoint, goals, points, True)
    try:
        assert lines.get(timeout=60).startswith("sent")
        assert lines.get(timeout=60).startswith("arrived")
        t0 = time.monotonic()
        rig.client.query("nav/stop", timeout=WAIT)
        answered = time.monotonic()
        replies = json.loads(lines.get(timeout=60))
    finally:
        end_child(proc)
    end = max(t for t, _ in replies) + BURST_AFTER
    rig.pose.first(lambda t, p: t > end, timeout=WAIT + BURST_AFTER)  # the stack ran on that long
    with rig.cmd.cond:
        moving = sum(1 for t, c in rig.cmd.items if answered < t <= end and (c.v, c.omega) != (0.0, 0.0))
    return Burst(
        goals,
        replies=len(replies),
        queued=sum(t > t0 for t, _ in replies),
        voided=sum(not ok for _, ok in replies),
        started=sum(ok and t > answered for t, ok in replies),
        moving=moving,
        answered=answered - t0,
    )


@dataclass
class Gap:
    """The longest interval between poses around one bad input, and what refused it."""

    what: str
    gap: float  # [s]
    counter: str  # service.counter
    count: int  # its value after


def pose_gap(rig: StackRig, what: str, service: str, counter: str, send: Callable[[], object]) -> Gap:
    """Send one bad input; the longest pose gap around it and the counter that must have grown."""
    before = rig.counter(service, counter)
    t0 = time.monotonic()
    send()
    count = rig.wait_counter(service, counter, before)
    rig.pose.first(lambda t, p: t > t0 + GAP_AFTER, timeout=WAIT + GAP_AFTER)
    return Gap(what, rig.pose.max_gap(t0 - GAP_BEFORE, t0 + GAP_AFTER), f"{service}.{counter}", count)


def bad_inputs(rig: StackRig) -> list[Gap]:
    """Each bad input once: a 200 kB selector parameter, a payload over max_payload, a clock at rtf 200 (as if from the
    clock's owner), a clock 5 s behind from another sender, an encoder 0.9 s ahead."""
    s = rig.session
    rig.pose.first(lambda t, p: True)
    t0 = time.monotonic()
    rig.pose.first(lambda t, p: t > t0 + GAP_AFTER + GAP_BEFORE, timeout=WAIT)
    quiet = Gap("nothing (baseline)", rig.pose.max_gap(t0, t0 + GAP_AFTER + GAP_BEFORE), "-", 0)
    key = rig.client.key
    return [
        quiet,
        pose_gap(
            rig,
            "200 kB selector parameter",
            "navigator",
            "oversize",
            lambda: _get(s, f"{key('nav/follow_path')}?points={'1' * BIG_PARAMS}"),
        ),
        pose_gap(
            rig,
            "1 MiB + 1 byte payload on sensors/encoders",
            "odometry",
            "oversize",
            lambda: s.put(key("sensors/encoders"), bytes(OVER_PAYLOAD), congestion_control=zenoh.CongestionControl.BLOCK),
        ),
        pose_gap(
            rig,
            "clock sample at rtf 200",
            "localizer",
            "clock_refused",
            lambda: rig.client.publish("clock", m.Clock(t=rig.clock.msg.t + 0.01, rtf=200.0, instance=rig.clock.msg.instance)),
        ),
        pose_gap(
            rig,
            "clock sample 5 s behind from another sender",
            "localizer",
            "clock_foreign",
            lambda: rig.client.publish("clock", m.Clock(t=max(rig.clock.msg.t - 5.0, 0.0), wall=time.time(), instance="stray")),
        ),
        pose_gap(
            rig,
            "encoder sample 0.9 s ahead",
            "odometry",
            "dropped_future",
            lambda: rig.client.publish("sensors/encoders", _ahead(rig.one("sensors/encoders"), rig.clock.msg.t + 0.9)),
        ),
    ]


@dataclass
class Edge:
    """A payload over the router's largest message ([limits] max_payload plus max_params plus headroom), sent
    through the router: Zenoh drops it there, so the service never copies it."""

    size: int  # [bytes] sent
    oversize: int  # the service's `oversize` counter: grown by how much (0: it never saw the payload)
    bad_input: int  # ... and its `bad_input`: the malformed sample sent after it on the same link, which it did see
    gap: float  # [s] the longest pose gap around it


def oversize_at_the_edge(rig: StackRig, size: int = BIG_PAYLOAD, query: bool = False) -> Edge:
    """A child process puts `size` bytes on sensors/encoders (`query`: asks localizer/pose with them), then a
    malformed sample (query) on the same session: a link delivers in order, so once the service counts the
    malformed one, the big one would have come before it. (From a process of its own: sent on the session that
    records the poses, its sending would delay their arrival here, whatever the stack does.)"""
    service, suffix = ("localizer", "localizer/pose") if query else ("odometry", "sensors/encoders")
    oversize, bad = rig.counter(service, "oversize"), rig.counter(service, "bad_input")
    proc, lines = start_child(big, rig.endpoint, rig.client.key(suffix), size, query)
    try:
        t0 = float(lines.get(timeout=60).split()[1])  # the child's session is open: it sends now
        after_bad = rig.wait_counter(service, "bad_input", bad)
        grown = rig.counter(service, "oversize") - oversize
        rig.pose.first(lambda t, p: t > t0 + GAP_AFTER, timeout=WAIT + GAP_AFTER)
    finally:
        end_child(proc)
    return Edge(size, grown, after_bad - bad, rig.pose.max_gap(t0 - GAP_BEFORE, t0 + GAP_AFTER))


@dataclass
class Wildcard:
    """A `get zenav/r1/**` while a goal runs."""

    replies: int  # answers of every queryable reached
    refused: int  # wildcard_refused summed over navigator, localizer and sim, after
    goal_before: tuple[int, str]  # (goal id, state) before the get
    goal_after: tuple[int, str]  # ... and a second after it
    jump: float  # [m] largest step of the true pose between samples 10 ms apart around the get
    pose_jump: float  # [m] largest step of the localizer's pose around the get


def wildcard_get(rig: StackRig) -> Wildcard:
    """Start a goal, ask `get zenav/r1/**`, and look at the goal, the sim and the localizer a second later."""
    rig.ready()
    rig.client.query("nav/move_to_point", {"x": -0.5, "y": 0.0}, timeout=WAIT)
    st = rig.nav.wait(lambda s: s.state != State.STOPPED, timeout=WAIT)
    truth: list[m.Truth] = []
    handle = rig.client.subscribe("sim/truth", truth.append)
    t0 = time.monotonic()
    replies = rig.bus.get(rig.client.key("**"), timeout=WAIT)
    rig.pose.first(lambda t, p: t > t0 + 1.0, timeout=WAIT)
    handle.undeclare()
    after = rig.nav.msg
    poses = [p for t, p in rig.pose.items if t >= t0 - 0.5]
    refused = sum(rig.counter(s, "wildcard_refused") for s in ("navigator", "localizer", "sim"))
    rig.client.query("nav/stop", timeout=WAIT)
    return Wildcard(len(replies), refused, (st.goal_id, st.state), (after.goal_id, after.state), _steps(truth), _steps(poses))


def _steps(poses: list[Any]) -> float:
    """[m] the largest step between consecutive poses."""
    return max((math.hypot(b.x - a.x, b.y - a.y) for a, b in zip(poses, poses[1:], strict=False)), default=0.0)


def echoed_field(rig: StackRig, chars: int = 500_000) -> int:
    """[bytes] the error reply to a goal with an unknown field of `chars` characters (its decode error names it)."""
    payload = codec.encode({"x": 0.0, "y": 0.0, "a" * chars: 1})
    replies = rig.bus.get(rig.client.key("nav/move_to_point"), payload=payload, timeout=WAIT)
    return max(len(data) for _, data in replies)


def _ahead(enc: m.Encoders, t: float) -> m.Encoders:
    return m.Encoders(t=t, left=enc.left, right=enc.right)


def _get(session: zenoh.Session, selector: str) -> list[bytes]:
    return [r.err.payload.to_bytes() if r.err is not None else b"" for r in session.get(selector, timeout=WAIT)]


def measure(floods: int = 1) -> None:
    """Measure and print the figures: each once, the stop under a flood `floods` times."""
    with tempfile.TemporaryDirectory(prefix="zenav-safety-") as logs:
        _measure(StackRig(Path(logs)), floods)


def _spread(values: list[float]) -> str:
    """min / median / max in ms."""
    return " / ".join(f"{v * 1000:.1f}" for v in (min(values), statistics.median(values), max(values)))


def _measure(rig: StackRig, floods: int) -> None:
    try:
        for cli in (False, True):
            f = frozen_operator(rig, cli)
            who = "zenav goto --wait" if cli else "a Robot"
            print(f"frozen operator ({who}, SIGSTOP mid-goal): zero cmd_vel after {f.cmd_vel:.3f} s, ", end="")
            print(f"zero wheels after {f.wheels:.3f} s ({f.message})")
        runs = [stop_under_flood(rig) for _ in range(floods)]
        fl = runs[0]
        print(
            f"nav/stop after {fl.goals} follow_path goals of {FLOOD_POINTS} points: answered in {fl.answered * 1000:.1f} ms, "
            f"zero cmd_vel {fl.zero * 1000:.1f} ms, {fl.after} of the goals answered after it"
        )
        if floods > 1:
            print(
                f"  over {floods} runs, min / median / max: answered {_spread([r.answered for r in runs])} ms, "
                f"zero cmd_vel {_spread([r.zero for r in runs])} ms; "
                f"under 50 ms: answered {sum(r.answered < 0.05 for r in runs)}, zero {sum(r.zero < 0.05 for r in runs)}"
            )
        b = stop_after_a_burst(rig)
        print(
            f"nav/stop once {b.goals} follow_path goals of {FLOOD_POINTS} points reached the navigator: answered in "
            f"{b.answered * 1000:.1f} ms; {b.queued} goals still there, {b.voided} voided, {b.started} started after it, "
            f"{b.moving} moving cmd_vel after it"
        )
        for g in bad_inputs(rig):
            print(f"largest pose gap, {g.what}: {g.gap * 1000:.0f} ms ({g.counter} = {g.count})")
        for query, what in ((False, "on sensors/encoders (odometry)"), (True, "as a localizer/pose query (localizer)")):
            e = oversize_at_the_edge(rig, query=query)
            print(f"largest pose gap, {e.size} bytes {what}: {e.gap * 1000:.0f} ms; oversize +{e.oversize}, ", end="")
            print(f"the malformed input after it: bad_input +{e.bad_input}")
        w = wildcard_get(rig)
        print(
            f"get zenav/r1/**: {w.replies} replies, wildcard_refused {w.refused}; goal {w.goal_before} -> {w.goal_after}; "
            f"largest step {w.jump * 100:.1f} cm true, {w.pose_jump * 100:.1f} cm localized"
        )
    finally:
        rig.close()
