"""WPILib's DifferentialDrivePoseEstimator beside zenav's localizer, on the same sensor stream.

    zenav bench studies peers --seeds 5   # the world model's streams (default, coarse, harsh)
    zenav bench peers                     # those and the live stack's recordings, into the report

What FIRST teams run (robotpy-wpimath, `pip install 'zenav[peers]'`) is fed what the
localizer is fed: the wheels' travel from the encoder counts (nominal wheel radius), the
gyro's heading (its rate integrated, as a team's IMU reports it), and each VPS fix when it
arrives, through `addVisionMeasurement` at its capture stamp. On the world model's streams
both start at the robot's true starting pose (a team sets it at the start of a match:
WPILib's constructor, zenav's `localizer/set_pose`); on the live stack's recordings zenav's
localizer started unplaced and was placed by the fixes, WPILib at the true pose. Both are
scored the same way at every sample after the warm-up (shared/spec/scenarios.md, "Scores").

WPILib is run with its documented default standard deviations, then over a small sweep
of its state and vision standard deviations, with and without the rejection FRC teams
add in front of it (a fix further than `gate` from its own estimate at the capture time
is dropped: WPILib has none); its best is reported beside the default.
"""

from __future__ import annotations

import heapq
import math
import statistics
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

from zenav.bench import accuracy
from zenav.bench.scoring import WARMUP, Score, score
from zenav.bench.studies.harness import Streams, arrival
from zenav.bench.studies.localizer import drive_square, evaluate
from zenav.common import extras
from zenav.common import messages as m
from zenav.common.config import RobotConfig
from zenav.common.scenarios import scenario
from zenav.common.track import Track
from zenav.services.localizer.base import LocalizerConfig
from zenav.services.localizer.modes import make_mode
from zenav.services.odometry.odometry import tick_delta

TARGET = 2.5  # WPILib's best RMSE over zenav's, on the same stream, at least (reported, not asserted)
Sigmas = tuple[float, float, float]  # [m], [m], [rad]: x, y, heading


@dataclass(frozen=True)
class Tuning:
    """WPILib's settings: its standard deviations, and a team's rejection of far fixes in front of it."""

    state: Sigmas
    vision: Sigmas
    gate: float | None = None  # [m] a fix further than this from the estimate at its capture time is dropped (None: none)

    def label(self) -> str:
        gate = "none" if self.gate is None else f"{self.gate:g} m"
        return f"state {_sigmas(self.state)}, vision {_sigmas(self.vision)}, gate {gate}"


DEFAULT = Tuning(state=(0.02, 0.02, 0.01), vision=(0.1, 0.1, 0.1))  # WPILib's documented defaults for a differential drive
STATES: tuple[Sigmas, ...] = ((0.005, 0.005, 0.002), (0.02, 0.02, 0.01), (0.1, 0.1, 0.05))
# The scenario's own VPS noise (2 cm, 2 deg) and coarser: the sweep a team would try.
VISIONS: tuple[Sigmas, ...] = ((0.02, 0.02, 0.035), (0.05, 0.05, 0.1), (0.1, 0.1, 0.1), (0.3, 0.3, 0.3))
GATES: tuple[float | None, ...] = (None, 0.25)  # [m] 0.25: half the outliers' 0.5 m displacement
SWEEP: tuple[Tuning, ...] = tuple(Tuning(s, v, g) for s in STATES for v in VISIONS for g in GATES)


def _sigmas(s: Sigmas) -> str:
    return "(" + ", ".join(f"{v:g}" for v in s) + ")"


def wpimath() -> ModuleType:
    """The wpimath package (robotpy-wpimath); MissingExtra when it is not installed."""
    return extras.require("wpimath", "the WPILib comparison", extra="peers")


def wheel_travel(encoders: Sequence[m.Encoders], robot: RobotConfig) -> list[tuple[float, float, float]]:
    """(t [s], left [m], right [m]) of each sample: each wheel's travel since the first, at the nominal radius
    (counts unwrapped from signed 32 bits, as the odometry does)."""
    per_tick = 2.0 * math.pi * robot.wheel_radius / (robot.ticks_per_rev or 360)
    out: list[tuple[float, float, float]] = []
    left = right = 0
    prev: m.Encoders | None = None
    for e in encoders:
        if prev is not None:
            left += tick_delta(e.left, prev.left)
            right += tick_delta(e.right, prev.right)
        out.append((e.t, left * per_tick, right * per_tick))
        prev = e
    return out


def run_wpilib(streams: Streams, robot: RobotConfig, tuning: Tuning, warmup: float = WARMUP) -> Score:
    """WPILib's estimator on the streams (encoders, IMU, fixes in arrival order), scored against their truth."""
    wpimath()
    from wpimath import estimator, geometry, kinematics

    first = streams.truth[0]
    travel = iter(wheel_travel(streams.encoders, robot))
    events: Iterable[tuple[float, int, object]] = heapq.merge(
        ((t, 0, f) for t, f in sorted(streams.fixes, key=arrival)),
        ((s.t, 1, s) for s in streams.imu),
        ((s.t, 3, s) for s in streams.encoders),
        key=lambda e: (e[0], e[1]),
    )
    est = None
    angle, t_gyro = 0.0, None  # [rad] the gyro's integral, [s] its newest sample
    t_last = -math.inf
    poses: list[tuple[float, float, float, float]] = []
    for _, _, msg in events:
        if isinstance(msg, m.Imu):
            if t_gyro is not None and msg.t > t_gyro:
                angle += msg.gyro_z * (msg.t - t_gyro)
            t_gyro = msg.t if t_gyro is None else max(t_gyro, msg.t)
        elif isinstance(msg, m.Encoders):
            t, left, right = next(travel)
            if est is None:
                start = geometry.Pose2d(first.x, first.y, geometry.Rotation2d(first.theta))
                kin = kinematics.DifferentialDriveKinematics(robot.track_width)
                est = estimator.DifferentialDrivePoseEstimator(
                    kin, geometry.Rotation2d(angle), left, right, start, tuning.state, tuning.vision
                )
            elif t <= t_last:
                continue  # a repeated stamp: WPILib's buffer takes each time once
            t_last = t
            p = est.updateWithTime(t, geometry.Rotation2d(angle), left, right)
            poses.append((t, p.X(), p.Y(), p.rotation().radians()))
        elif isinstance(msg, m.VpsPose) and est is not None:
            if tuning.gate is not None:
                at = est.sampleAt(msg.t)
                if at is None or math.hypot(at.X() - msg.x, at.Y() - msg.y) > tuning.gate:
                    continue
            est.addVisionMeasurement(geometry.Pose2d(msg.x, msg.y, geometry.Rotation2d(msg.theta)), msg.t)
    return score(poses, Track((s.t, s.x, s.y, s.theta) for s in streams.truth), warmup)


def run_zenav(streams: Streams, robot: RobotConfig) -> Score:
    """zenav's localizer (its default config) on the same streams, given the true start as WPILib is, scored the same way."""
    loc = make_mode(LocalizerConfig(), robot)
    first = streams.truth[0]
    loc.set_pose(first.t, first.x, first.y, first.theta)
    return evaluate(loc, streams.odom, streams.fixes, streams.truth, streams.imu, streams.compass)


@dataclass(frozen=True)
class Compared:
    """One stream: zenav's score, WPILib's with its defaults and with the best tuning of the sweep."""

    zenav: Score
    default: Score
    best: Score
    tuning: Tuning  # the best's

    @property
    def ratio(self) -> float:
        """WPILib's best RMSE over zenav's (above 1: zenav is better)."""
        return self.best.rmse / self.zenav.rmse


def compare(streams: Streams, robot: RobotConfig, zenav: Score | None = None, sweep: Sequence[Tuning] = SWEEP) -> Compared:
    """WPILib on the streams with its defaults and over `sweep`, beside zenav's score (None: replayed on them)."""
    default = run_wpilib(streams, robot, DEFAULT)
    tried = [(run_wpilib(streams, robot, t), t) for t in sweep if t != DEFAULT]
    best, tuning = min([(default, DEFAULT), *tried], key=lambda st: st[0].rmse)
    return Compared(zenav or run_zenav(streams, robot), default, best, tuning)


def recorded(msgs: dict[str, list[Any]], fixes: list[tuple[float, m.VpsPose]]) -> Streams:
    """The streams of a live run's recording (bench/trials.py's Recorder): what the localizer was sent."""
    return Streams(
        truth=msgs["sim/truth"],
        odom=msgs["odom"],
        imu=msgs["sensors/imu"],
        compass=msgs["sensors/compass"],
        encoders=msgs["sensors/encoders"],
        fixes=fixes,
    )


def study(
    scenarios: Sequence[str], seeds: Sequence[int], duration: float = 60.0, sweep: Sequence[Tuning] = SWEEP
) -> dict[str, list[Compared]]:
    """Each scenario's square on the world model (bench/studies/harness.py), one comparison per seed."""
    out: dict[str, list[Compared]] = {}
    for name in scenarios:
        sc = scenario(name)
        robot = RobotConfig(ticks_per_rev=sc.ticks_per_rev)
        out[name] = [compare(drive_square(sc, seed, duration), robot, sweep=sweep) for seed in seeds]
    return out


def live(
    scenarios: Sequence[str],
    sources: Sequence[str],
    seed: int,
    laps: float,
    rtfs: dict[str, float],
    logs: Path,
    note: Callable[[str], None],
) -> dict[str, list[Compared]]:
    """Each scenario's square on the live stack (separate processes) with each VPS source, its recording fed to WPILib
    beside what the stack's own localizer made of it; `rtfs`: the realtime factor per VPS source."""
    out: dict[str, list[Compared]] = {}
    for vps in sources:
        for name in scenarios:
            spec = accuracy.Spec(scenario=name, seed=seed, laps=laps, vps=vps)
            r = accuracy.run(spec, rtfs[vps], logs / f"peers-{name}-{vps}")
            rec = r.trial.rec
            c = compare(recorded(rec.msgs, rec.fixes()), r.settings.robot, zenav=r.pose)
            out[f"{name}, {vps} VPS, live stack, seed {seed}"] = [c]
            note(f"peers, {name}, {vps} VPS: zenav {c.zenav.rmse * 100:.2f} cm, WPILib's best {c.best.rmse * 100:.2f} cm")
    return out


def row(label: str, runs: Sequence[Compared]) -> str:
    """A markdown row: zenav's RMSE, WPILib's default and best [cm] (means over the runs), the ratio, the best tuning."""
    mean = statistics.fmean
    z, d, b = (mean([getattr(c, k).rmse for c in runs]) * 100 for k in ("zenav", "default", "best"))
    tunings = sorted({c.tuning.label() for c in runs})
    met = "yes" if b / z >= TARGET else "**no**"
    return f"| {label} | {z:.2f} | {d:.2f} | {b:.2f} | {b / z:.2f}x | {met} | {'; '.join(tunings)} |"


INTRO = (
    "What FIRST teams run, robotpy-wpimath's DifferentialDrivePoseEstimator, fed the stream zenav's localizer got: the"
    " encoders' wheel travel, the gyro's integrated heading, each VPS fix as it arrived at its capture stamp (all"
    " simulated: the scenario's robot, sensors and camera). WPILib with its documented defaults, and its best over a"
    f" sweep of {len(SWEEP)} settings of its state and vision standard deviations, with and without a team's rejection"
    " of fixes far from its estimate (bench/peers.py). On the world model both start at the robot's true starting pose"
    " (WPILib's constructor, zenav's set_pose); in the live stack zenav was placed by the fixes, WPILib at the true"
    " pose. RMSE of the position after the warm-up, means over the seeds."
)
HEADER = (
    f"| stream | zenav RMSE cm | WPILib default cm | WPILib best cm | best / zenav (goal >= {TARGET:g}x) | met | WPILib's best tuning |",
    "|---|---|---|---|---|---|---|",
)


def lines(results: dict[str, list[Compared]]) -> list[str]:
    """The markdown table of `results` (stream label -> its comparisons)."""
    return [*HEADER, *(row(label, runs) for label, runs in results.items())]


def short_sweep() -> tuple[Tuning, ...]:
    """A few tunings of the sweep (the scenario's VPS noise, with and without the gate): for tests."""
    return tuple(t for t in SWEEP if t.state == DEFAULT.state and t.vision == VISIONS[0])
