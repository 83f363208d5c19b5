"""The odometry study: how far dead reckoning drifts with each heading source, on the world model.

    zenav bench studies odometry [--seeds 10] [--scenarios default coarse harsh]

Drives 3 laps of a 1 m square (straight at 0.2 m/s, turns in place at 1 rad/s) with
open-loop wheel commands on one offline trial each (harness.py: the robot, its
sensors and the odometry service's core), and reports the final position error and
the largest heading jump in odom (a heading change the true motion does not explain).
The estimate_average rows are the 12-estimate average (the localizer's estimate_average mode
with no fixes) on the encoders' odometry and the IMU: encoder and accelerometer distances with
encoder, gyro and accelerometer angle changes, weighted-averaged.
"""

from __future__ import annotations

import heapq
import math
import statistics
from collections.abc import Sequence
from typing import NamedTuple

import msgspec

from zenav.bench.studies.harness import Command, Trial, odometry_config
from zenav.common import messages as m
from zenav.common.config import RobotConfig, Settings
from zenav.common.geometry import wrap_angle
from zenav.services.localizer.base import LocalizerConfig
from zenav.services.localizer.estimate_average import EstimateAverage
from zenav.services.odometry.service import OdometryConfig

SPEED, TURN_RATE = 0.2, 1.0  # [m/s], [rad/s]


def square(robot: RobotConfig, laps: int = 3) -> list[tuple[float, float, float]]:
    """Segments (duration [s], left, right wheel command [rad/s]) of `laps` 1 m squares."""
    r, half = robot.wheel_radius, robot.track_width / 2.0
    drive, turn = SPEED / r, TURN_RATE * half / r
    segs = [(1.0, 0.0, 0.0)]  # standing still first: the gyro and compass settle
    for _ in range(laps * 4):
        segs += [(1.0 / SPEED, drive, drive), (0.2, 0.0, 0.0), ((math.pi / 2) / TURN_RATE, -turn, turn), (0.2, 0.0, 0.0)]
    return segs


class OpenLoop:
    """Wheel commands from a list of segments, one per sample, then stop."""

    def __init__(self, segments: Sequence[tuple[float, float, float]], rate: float) -> None:
        self.commands = [(left, right) for duration, left, right in segments for _ in range(round(duration * rate))]

    def __call__(self, trial: Trial) -> Command | None:
        return self.commands[trial.steps] if trial.steps < len(self.commands) else None


def run(settings: Settings, cfg: OdometryConfig, seed: int) -> tuple[float, float]:
    """(final position error [m], largest unexplained heading step [rad]) of one drive."""
    trial = Trial(settings.robot, settings.scenario, seed, odometry=cfg, camera=False)
    controller = OpenLoop(square(settings.robot), trial.rate)
    trial.run(controller, len(controller.commands) / trial.rate + 1.0)
    return _errors(trial, [(o.t, o.x, o.y, o.theta) for o in trial.streams.odom])


def run_estimate_average(settings: Settings, overrides: dict[str, object], seed: int) -> tuple[float, float]:
    """run() of the 12-estimate average: the estimate_average mode (localizer overrides, no fixes) on the encoders' odom and the IMU."""
    trial = Trial(settings.robot, settings.scenario, seed, odometry=odometry_config(heading_source="encoders"), camera=False)
    controller = OpenLoop(square(settings.robot), trial.rate)
    trial.run(controller, len(controller.commands) / trial.rate + 1.0)
    mode = EstimateAverage(msgspec.convert({"mode": "estimate_average", **overrides}, LocalizerConfig), settings.robot)
    events = heapq.merge(((s.t, 0, s) for s in trial.streams.imu), ((s.t, 1, s) for s in trial.streams.odom), key=lambda e: (e[0], e[1]))
    poses = []
    for _, _, msg in events:
        if isinstance(msg, m.Imu):
            mode.on_imu(msg)
        elif isinstance(msg, m.Odom) and mode.on_odom(msg) is None and (p := mode.get_pose()) is not None:
            poses.append((p.t, p.x, p.y, p.theta))
    return _errors(trial, poses)


def _errors(trial: Trial, poses: Sequence[tuple[float, float, float, float]]) -> tuple[float, float]:
    """(final position error [m], largest unexplained heading step [rad]) of poses (t, x, y, theta) against the truth."""
    truth = {s.t: s.theta for s in trial.streams.truth}
    jump = 0.0
    for a, b in zip(poses, poses[1:]):
        jump = max(jump, abs(wrap_angle((b[3] - a[3]) - (truth[b[0]] - truth[a[0]]))))
    end, s = poses[-1], trial.bot.state
    return math.hypot(end[1] - s.x, end[2] - s.y), jump


class Row(NamedTuple):
    scenario: str
    label: str
    final_cm: float
    jump_deg: float


CONFIGS: list[tuple[str, dict[str, object]]] = [
    ("encoders", dict(heading_source="encoders")),
    ("gyro", dict(heading_source="gyro")),
    ("compass, gain 1 (replace)", dict(heading_source="compass", compass_gain=1.0)),
    ("compass, gain 0.1 (default)", dict(heading_source="compass")),
    ("blend 1:3:0", dict(heading_source="blend", blend_encoders=1.0, blend_gyro=3.0, blend_accel=0.0)),
]
# The 12-estimate average: [localizer] estimate_average_* weights (distances: encoders, accel; angles: encoders, gyro, accel).
ESTIMATE_AVERAGE_CONFIGS: list[tuple[str, dict[str, object]]] = [
    (
        f"estimate_average dist {d[0]:g}:{d[1]:g}, angle {a[0]:g}:{a[1]:g}:{a[2]:g}",
        dict(estimate_average_distance_weights=d, estimate_average_angle_weights=a),
    )
    for d, a in (((1.0, 0.0), (1.0, 3.0, 0.0)), ((1.0, 0.1), (1.0, 3.0, 0.0)), ((1.0, 0.0), (1.0, 3.0, 0.3)), ((1.0, 1.0), (1.0, 1.0, 1.0)))
]


def evaluate(scenarios: Sequence[str], seeds: int) -> list[Row]:
    """One row per scenario and heading source: means over seeds 1..N."""
    rows = []
    for name in scenarios:
        settings = Settings.load(None, deployment={"scenario": name})
        for label, overrides in CONFIGS:
            results = [run(settings, odometry_config(**overrides), seed) for seed in range(1, seeds + 1)]
            final = statistics.fmean(r[0] for r in results)
            jump = statistics.fmean(r[1] for r in results)
            rows.append(Row(name, label, 100 * final, math.degrees(jump)))
        for label, overrides in ESTIMATE_AVERAGE_CONFIGS:
            results = [run_estimate_average(settings, overrides, seed) for seed in range(1, seeds + 1)]
            final = statistics.fmean(r[0] for r in results)
            jump = statistics.fmean(r[1] for r in results)
            rows.append(Row(name, label, 100 * final, math.degrees(jump)))
    return rows


def table(scenarios: Sequence[str], seeds: int) -> str:
    """The markdown table of `evaluate`."""
    lines = [
        f"3 laps of a 1 m square, mean of {seeds} seeds, arc integrator",
        "",
        "| scenario | heading source | final error [cm] | largest heading jump in odom [deg] |",
        "|---|---|---|---|",
    ]
    lines += [f"| {r.scenario} | {r.label} | {r.final_cm:.1f} | {r.jump_deg:.1f} |" for r in evaluate(scenarios, seeds)]
    return "\n".join(lines)
