"""The reference trials driven through a running stack's navigator, and what they record.

A `Recorder` keeps every message of one robot's run (truth, odometry, sensors,
fixes, poses); the trials send goals with `wait` and note when each ended; `score`
turns a recording into the localization error of shared/spec/scenarios.md.
"""
from __future__ import annotations

import itertools
import math
import threading
import time
from dataclasses import dataclass, field
from typing import Any, Optional, Sequence

import numpy as np

from zenav.common import messages as m
from zenav.common.client import Client, ClientError
from zenav.common.geometry import wrap_angle
from zenav.services.navigator.evaluate import HEADINGS, PATH, SQUARE
from zenav.tools import plot

WARMUP = 2.0  # [s] of stack time before scoring starts and before the first goal (the localizer's first fixes)
GOAL_TIMEOUT = 60.0  # [s] of stack time a goal may take
RECOVER = 1.0  # [s] of stack time poses must flow again after a failed goal before the next (not a burst of refusals)
RECORDED = ("sim/truth", "odom", "pose", "vps/pose", "localizer/fixes", "sensors/imu", "sensors/compass")


class Recorder:
    """Every message of the recorded topics of one robot, in arrival order."""

    def __init__(self, client: Client) -> None:
        self.msgs: dict[str, list[Any]] = {topic: [] for topic in RECORDED}
        for topic in RECORDED:
            client.subscribe(topic, self.msgs[topic].append)

    def series(self, topic: str) -> list[plot.Sample]:
        """(t, x, y, theta) of a pose-like topic, for plots and scores."""
        return [(s.t, s.x, s.y, s.theta) for s in self.msgs[topic]]

    def fixes(self) -> list[tuple[float, m.VpsPose]]:
        """(arrival at the localizer [s], fix) of every fix the localizer audited."""
        arrival = {f.t: f.t_arrival for f in self.msgs["localizer/fixes"]}
        return [(arrival[f.t], f) for f in self.msgs["vps/pose"] if f.t in arrival]

    def truth_at(self, t: float) -> tuple[float, float, float]:
        """Truth (x, y, theta) interpolated at t."""
        tr = np.array(sorted(self.series("sim/truth")))
        th = np.interp(t, tr[:, 0], np.unwrap(tr[:, 3]))
        return float(np.interp(t, tr[:, 0], tr[:, 1])), float(np.interp(t, tr[:, 0], tr[:, 2])), wrap_angle(float(th))


@dataclass(frozen=True)
class Score:
    """Localization error of one run after the warm-up: position [m], heading [rad]."""

    rmse: float
    max: float
    final: float
    heading_rmse: float
    n: int


def score(est: Sequence[plot.Sample], truth: Sequence[plot.Sample], warmup: float = WARMUP) -> Score:
    """The error of an estimate's series against the truth at its t, from `warmup` on."""
    t, pos, th = plot.errors(est, truth)
    keep = t >= (t[0] if len(t) else 0.0) + warmup
    pos, th = pos[keep], th[keep]
    if not len(pos):
        return Score(math.nan, math.nan, math.nan, math.nan, 0)
    return Score(plot.rms(pos), float(pos.max()), float(pos[-1]), plot.rms(th), len(pos))


@dataclass(frozen=True)
class GoalEnd:
    """One goal of a trial: what was asked, how it ended, when (stack time [s])."""

    kind: str  # point, path or turn
    target: tuple[float, ...]  # (x, y) for point and path (the last point), (heading,) for a turn
    result: str  # succeeded, cancelled, aborted, or the client error
    t_start: float
    t_end: float
    message: str = ""  # why, when it did not succeed


@dataclass
class Trial:
    """The goals of a run, and its recording."""

    rec: Recorder
    goals: list[GoalEnd] = field(default_factory=list)

    def errors(self, kind: str) -> list[float]:
        """Truth error of each succeeded goal of a kind: [m] to the point, or [rad] to the heading."""
        out = []
        for g in self.goals:
            if g.kind == kind and g.result == "succeeded":
                x, y, th = self.rec.truth_at(g.t_end)
                out.append(abs(wrap_angle(th - g.target[0])) if kind == "turn" else math.dist((x, y), g.target))
        return out

    def durations(self, kind: str) -> list[float]:
        return [g.t_end - g.t_start for g in self.goals if g.kind == kind and g.result == "succeeded"]


def wait_ready(client: Client, services: Sequence[str], rtf: float, timeout: float = 60.0) -> None:
    """Block until every service is alive and the stack clock has passed the warm-up."""
    client.wait_alive(services, timeout=timeout)
    pose = client.latest("pose")
    p = pose.wait(lambda p: p.t >= WARMUP, timeout=timeout + WARMUP / rtf)
    if "navigator" in services:  # and until a goal would start (the first fixes are in), asking on new poses
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            try:
                if not client.query("nav/status", timeout=5.0).not_ready:
                    return
            except ClientError:
                pass  # a loaded navigator that does not answer in time: ask again; the goals say the rest
            p = pose.wait(lambda q, t=p.t: q.t >= t + 0.1, timeout=timeout)


def _goal(client: Client, rtf: float, kind: str, query: str, request: dict, target: tuple) -> GoalEnd:
    t_start = client.latest("pose").msg.t  # there is one: wait_ready saw it
    try:
        rep = client.query(query, {**request, "wait": True}, timeout=GOAL_TIMEOUT / rtf + 10.0)
        result, t_end, message = rep.result or rep.state, rep.pose.t if rep.pose is not None else math.nan, rep.message
    except ClientError as e:
        result, t_end, message = e.code, math.nan, e.message
    if result not in ("succeeded", "cancelled"):
        since = client.latest("pose").msg.t
        try:
            client.latest("pose").wait(lambda p: p.t >= since + RECOVER, timeout=GOAL_TIMEOUT / rtf)
        except TimeoutError:
            pass  # the next goal will say how things stand
    return GoalEnd(kind, target, result, t_start, t_end, message)


def square(client: Client, goals: list[GoalEnd], rtf: float, laps: float, stop: Optional[threading.Event] = None) -> None:
    """Seed 003's square: move_to_point around the 1 m square back to the start, `laps` times (or until `stop`)."""
    for x, y in itertools.islice(itertools.cycle(SQUARE), round(len(SQUARE) * laps)):
        if stop is not None and stop.is_set():
            return
        goals.append(_goal(client, rtf, "point", "nav/move_to_point", {"x": x, "y": y}, (x, y)))


def path(client: Client, goals: list[GoalEnd], rtf: float) -> None:
    """Seed 002's path trial: follow (1, 0) -> (1, 1) from the start."""
    request = {"points": [list(p) for p in PATH]}
    goals.append(_goal(client, rtf, "path", "nav/follow_path", request, PATH[-1]))


def turns(client: Client, goals: list[GoalEnd], rtf: float, headings_deg: Sequence[float] = HEADINGS) -> None:
    """turn_to_heading to each heading in turn (map frame)."""
    for deg in headings_deg:
        heading = math.radians(deg)
        goals.append(_goal(client, rtf, "turn", "nav/turn_to_heading", {"heading": heading}, (heading,)))


def drive(client: Client, goals: list[GoalEnd], stop: threading.Event, rtf: float) -> threading.Thread:
    """Drive squares in a thread until `stop` is set and the goal running then ends (nav/stop ends it at once)."""
    th = threading.Thread(target=square, args=(client, goals, rtf, 10**6, stop), name="zenav-bench-drive", daemon=True)
    th.start()
    return th
