"""The reference trials driven through a running stack's navigator, and what they record.

A `Recorder` keeps every message of one robot's run (truth, odometry, sensors,
fixes, poses); the trials send goals with `wait` and note when each ended;
bench/scoring.py turns a recording into the localization error of shared/spec/scenarios.md.
"""

from __future__ import annotations

import itertools
import math
import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import partial
from typing import Any

from zenav import services
from zenav.bench import scoring
from zenav.common import messages as m
from zenav.common.client import Client, ZenavError
from zenav.common.contract import GoalResult
from zenav.common.geometry import wrap_angle
from zenav.common.scenarios import HEADINGS, PATH, SQUARE
from zenav.common.track import Sample, Track
from zenav.robot import Goal, Robot

WARMUP = scoring.WARMUP  # [s] of stack time before the first goal too (the localizer's first fixes)
GOAL_TIMEOUT = 60.0  # [s] of stack time a goal may take
RECOVER = 1.0  # [s] of stack time poses must flow again after a failed goal before the next (not a burst of refusals)
ENDED_WELL = (GoalResult.SUCCEEDED, GoalResult.CANCELLED)  # goal results that are no failure (a stop cancels the goal running)
RECORDED = ("sim/truth", "odom", "pose", "vps/pose", "localizer/fixes", "sensors/imu", "sensors/compass", "sensors/encoders")


class Recorder:
    """Every message of the recorded topics of one robot, in arrival order."""

    def __init__(self, client: Client) -> None:
        self.msgs: dict[str, list[Any]] = {topic: [] for topic in RECORDED}
        for topic in RECORDED:
            client.subscribe(topic, self.msgs[topic].append)

    def series(self, topic: str) -> list[Sample]:
        """(t, x, y, theta) of a pose-like topic, for plots and scores."""
        return [(s.t, s.x, s.y, s.theta) for s in self.msgs[topic]]

    def fixes(self) -> list[tuple[float, m.VpsPose]]:
        """(arrival at the localizer [s], fix) of every fix the localizer audited."""
        arrival = {f.t: f.t_arrival for f in self.msgs["localizer/fixes"]}
        return [(arrival[f.t], f) for f in self.msgs["vps/pose"] if f.t in arrival]

    def truth(self) -> Track:
        """The truth of the run so far, to interpolate at any t."""
        return Track(self.series("sim/truth"))


@dataclass(frozen=True)
class TrialGoal:
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
    goals: list[TrialGoal] = field(default_factory=list)

    def errors(self, kind: str) -> list[float]:
        """Truth error of each succeeded goal of a kind: [m] to the point, or [rad] to the heading."""
        out, truth = [], self.rec.truth()
        for g in self.goals:
            if g.kind == kind and g.result == GoalResult.SUCCEEDED:
                x, y, th = truth.at(g.t_end)
                out.append(abs(wrap_angle(th - g.target[0])) if kind == "turn" else math.dist((x, y), g.target))
        return out

    def durations(self, kind: str) -> list[float]:
        return [g.t_end - g.t_start for g in self.goals if g.kind == kind and g.result == GoalResult.SUCCEEDED]


def wait_ready(bot: Robot, rtf: float, timeout: float = 60.0, names: Sequence[str] = services.NAMES) -> None:
    """Block until the stack clock has passed the warm-up and the navigator would take a goal (`names` running)."""
    bot.client.latest("pose").wait(lambda p: p.t >= WARMUP, timeout=timeout + WARMUP / rtf)
    bot.wait_ready(timeout, services=names)


def _goal(bot: Robot, rtf: float, kind: str, send: Callable[[], Goal], target: tuple[float, ...]) -> TrialGoal:
    """Send a goal and wait for its end, GOAL_TIMEOUT of stack time at most; after a failure,
    wait for RECOVER of stack time of poses (the robot settles before the next goal)."""
    poses = bot.client.latest("pose")
    t_start = poses.msg.t  # there is one: wait_ready saw it
    try:
        goal = send()
        end = goal.wait(timeout=GOAL_TIMEOUT / rtf + 10.0)
        state = goal.feedback()  # the navigator's nav/state at the end: its t is the end's
        t_end = state.t if state is not None and state.result is not None else end.pose.t if end.pose is not None else math.nan
        result, message = end.result, end.message
    except ZenavError as e:
        result, t_end, message = e.code, math.nan, e.message
    except TimeoutError as e:
        result, t_end, message = "timeout", math.nan, str(e)
    if result not in ENDED_WELL:
        since = poses.msg.t
        try:
            poses.wait(lambda p: p.t >= since + RECOVER, timeout=GOAL_TIMEOUT / rtf)
        except TimeoutError:
            pass  # the next goal will say how things stand
    return TrialGoal(kind, target, result, t_start, t_end, message)


def square(
    bot: Robot,
    goals: list[TrialGoal],
    rtf: float,
    laps: float,
    stop: threading.Event | None = None,
    corners: Sequence[tuple[float, float]] = SQUARE,
    speed: float | None = None,
    tolerance: float | None = None,
) -> None:
    """The square trial (or `corners`): move_to_point around it back to the start, `laps` times (or until `stop`);
    speed [m/s] and tolerance [m] default to the navigator's."""
    for x, y in itertools.islice(itertools.cycle(corners), round(len(corners) * laps)):
        if stop is not None and stop.is_set():
            return
        goals.append(_goal(bot, rtf, "point", partial(bot.move_to_point, x, y, speed=speed, tolerance=tolerance), (x, y)))


def path(bot: Robot, goals: list[TrialGoal], rtf: float) -> None:
    """The path trial: follow (1, 0) -> (1, 1) from the start."""
    goals.append(_goal(bot, rtf, "path", lambda: bot.follow_path(PATH), PATH[-1]))


def turns(bot: Robot, goals: list[TrialGoal], rtf: float, headings_deg: Sequence[float] = HEADINGS) -> None:
    """turn_to_heading to each heading in turn (map frame)."""
    for deg in headings_deg:
        heading = math.radians(deg)
        goals.append(_goal(bot, rtf, "turn", partial(bot.turn_to_heading, heading), (heading,)))


def drive(
    bot: Robot,
    goals: list[TrialGoal],
    stop: threading.Event,
    rtf: float,
    corners: Sequence[tuple[float, float]] = SQUARE,
    speed: float | None = None,
    tolerance: float | None = None,
) -> threading.Thread:
    """Drive squares in a thread until `stop` is set and the goal running then ends (Robot.stop ends it at once)."""
    th = threading.Thread(
        target=square, args=(bot, goals, rtf, 10**6, stop, corners, speed, tolerance), name="zenav-bench-drive", daemon=True
    )
    th.start()
    return th


def failed(goals: Sequence[TrialGoal]) -> list[str]:
    """The goals that did not succeed (a stop's cancel aside): target, result, why."""
    return [f"{g.target}: {g.result}: {g.message}" for g in goals if g.result not in ENDED_WELL]
