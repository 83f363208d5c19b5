"""The navigator study: its goal machine driving the world model's robot, alone.

    zenav bench studies navigator [--seeds 10]

Each goal runs on one offline trial (harness.py: the scenario's motor lag, deadband,
saturation, wheel slip, wheel/track errors and encoders). The pose the machine is
given is the truth plus an optional localizer-like error (a random walk that jumps at
the VPS rate, as fixes correct the estimate), with the speeds of the odometry
(encoders only). Everything is seeded; `report()` gives the tables of docs/how-it-works.md.
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Sequence
from dataclasses import dataclass

import msgspec
import numpy as np

from zenav.bench.scoring import summary
from zenav.bench.studies.harness import Command, Trial
from zenav.common.config import RobotConfig
from zenav.common.contract import GoalResult, State
from zenav.common.geometry import wrap_angle
from zenav.common.scenarios import HEADINGS, PATH, PRESETS, SQUARE, Scenario
from zenav.services.navigator.controllers import PoseSample, Wheelbase, check_polar_gains
from zenav.services.navigator.goals import End, Goal, GoalMachine
from zenav.services.navigator.params import CONTROLLERS, Params

ERROR_STREAM = 0x4E4156  # "NAV": seed stream of the estimate's error, apart from the world's
TIMEOUT = 120.0  # [s] a goal that has not ended by then is a timeout
SETTLE = 0.5  # [s] the robot comes to rest after a goal before it is measured


HEADING_ARM = 0.3  # [m] the default heading error is the position error seen over this arm (the VPS's heading from positions)


class PoseError:
    """The estimate's error: AR(1) at the VPS rate (each fix pulls it back and adds a new one)."""

    def __init__(self, sigma: float, rate: float, seed: int, heading_sigma: float | None = None) -> None:
        self.sigma = sigma  # [m] 1 sigma of the position error
        self.heading_sigma = sigma / HEADING_ARM if heading_sigma is None else heading_sigma  # [rad]
        self.period = 1.0 / rate  # [s]
        self.rng = np.random.default_rng([seed, ERROR_STREAM])
        self.err = (0.0, 0.0, 0.0)  # (x [m], y [m], theta [rad])
        self._since = 0.0  # [s] since the last jump

    def advance(self, dt: float) -> None:
        """Time moves on by dt [s]: at each VPS period the error jumps."""
        self._since += dt
        if self.sigma > 0 and self._since >= self.period:
            self._since, keep = 0.0, 0.8
            sig = np.array([self.sigma, self.sigma, self.heading_sigma]) * math.sqrt(1 - keep**2)
            ex, ey, eth = (keep * np.array(self.err) + sig * self.rng.standard_normal(3)).tolist()
            self.err = (ex, ey, eth)

    def estimate(self, trial: Trial) -> PoseSample:
        """The pose as the localizer would give it: truth plus the error, speeds of the odometry, the error's sigmas."""
        s, odom, (ex, ey, eth) = trial.bot.state, trial.odom, self.err
        v, omega = (odom.v, odom.omega) if odom is not None and odom.t == trial.t else (0.0, 0.0)
        return PoseSample(trial.t, s.x + ex, s.y + ey, wrap_angle(s.theta + eth), v, omega, self.sigma, self.heading_sigma)


@dataclass(frozen=True)
class Outcome:
    """One goal driven to its end on the world model's robot."""

    result: str
    message: str
    duration: float  # [s]
    x: float  # [m] true position at the end
    y: float
    theta: float  # [rad]
    overshoot: float  # [rad] turns: furthest the true heading went past the target


class GoalDriver:
    """The controller of one goal: the machine's command from each pose, acting from the next step."""

    def __init__(self, machine: GoalMachine, goal: Goal, error: PoseError, trial: Trial) -> None:
        self.machine, self.goal, self.error = machine, goal, error
        self.t0 = trial.t
        machine.on_pose(error.estimate(trial))
        machine.start(goal, self.t0)
        self.side = math.copysign(1.0, wrap_angle(goal.heading - trial.bot.state.theta))
        self.check_every = round(machine.params.check_period / trial.dt)  # [steps]
        self.end: End | None = None
        self.overshoot = 0.0  # [rad]
        self.first = True

    def __call__(self, trial: Trial) -> Command | None:
        if self.first:  # the goal starts at rest: its first command acts from the next step
            self.first = False
            return 0.0, 0.0
        self.error.advance(trial.dt)
        cmd, self.end = self.machine.on_pose(self.error.estimate(trial))
        if self.end is None and (trial.steps - round(self.t0 * trial.rate)) % self.check_every == 0:
            self.end = self.machine.check(trial.t)
        if self.goal.state == State.TURNING_TO_HEADING:
            self.overshoot = max(self.overshoot, -self.side * wrap_angle(self.goal.heading - trial.bot.state.theta))
        return None if self.end is not None else trial.bot.wheels(*(cmd or (0.0, 0.0)))


def drive(trial: Trial, machine: GoalMachine, goal: Goal, error: PoseError, timeout: float = TIMEOUT) -> Outcome:
    """Run one goal to its end, let the robot come to rest, and measure it."""
    driver = GoalDriver(machine, goal, error, trial)
    trial.run(driver, timeout)
    duration = trial.t - driver.t0
    trial.run(lambda tr: (0.0, 0.0), SETTLE)
    end, s = driver.end, trial.bot.state
    result, message = (end.result, end.message) if end else ("timeout", "")
    return Outcome(result, message, duration, s.x, s.y, s.theta, driver.overshoot)


def _trial(scenario: Scenario, seed: int) -> Trial:
    """A trial of the nominal robot, with the scenario's encoders, without the camera."""
    return Trial(RobotConfig(ticks_per_rev=scenario.ticks_per_rev), scenario, seed, camera=False)


def _machine(params: Params, trial: Trial) -> GoalMachine:
    r = trial.bot.robot
    return GoalMachine(params, Wheelbase(r.track_width, r.wheel_radius, r.max_wheel_speed))


def path_trial(params: Params, scenario: Scenario, seed: int, pose_sigma: float = 0.0) -> Outcome:
    """The path trial: from (0, 0, 0) follow (1, 0) -> (1, 1)."""
    goal = Goal(State.FOLLOWING_PATH, points=PATH, speed=params.speed, tolerance=params.tolerance)
    trial = _trial(scenario, seed)
    return drive(trial, _machine(params, trial), goal, PoseError(pose_sigma, scenario.vps_rate_hz, seed))


def square_trial(params: Params, scenario: Scenario, seed: int, pose_sigma: float = 0.0, laps: int = 3) -> list[Outcome]:
    """The square trial: move_to_point around a 1 m square and back to the start, `laps` times."""
    trial = _trial(scenario, seed)
    machine, error = _machine(params, trial), PoseError(pose_sigma, scenario.vps_rate_hz, seed)
    goals = (Goal(State.MOVING_TO_POINT, points=(p,), speed=params.speed, tolerance=params.tolerance) for p in SQUARE * laps)
    return [drive(trial, machine, goal, error) for goal in goals]


def turn_sweep(params: Params, scenario: Scenario, seed: int, headings_deg: Sequence[float], pose_sigma: float = 0.0) -> list[Outcome]:
    """turn_to_heading from 0 to each heading (each from a fresh robot at rest)."""
    out = []
    for i, deg in enumerate(headings_deg):
        goal = Goal(State.TURNING_TO_HEADING, heading=math.radians(deg), speed=params.turn_speed, tolerance=params.heading_tolerance)
        trial = _trial(scenario, seed * 1000 + i)
        out.append(drive(trial, _machine(params, trial), goal, PoseError(pose_sigma, scenario.vps_rate_hz, seed * 1000 + i)))
    return out


def compare(params: Params, scenario: Scenario, seeds: int, pose_sigma: float = 0.0) -> str:
    """One table row: path trial and square of one controller, as markdown cells."""
    paths = [path_trial(params, scenario, s, pose_sigma) for s in range(seeds)]
    squares = [square_trial(params, scenario, s, pose_sigma) for s in range(seeds)]
    err = summary([100 * math.dist((o.x, o.y), PATH[-1]) for o in paths])
    corners = [100 * math.dist((o.x, o.y), c) for sq in squares for o, c in zip(sq, SQUARE * 3)]
    failed = sum(o.result != GoalResult.SUCCEEDED for o in paths + [o for sq in squares for o in sq])
    return (
        f"{err[0]:.2f} / {err[1]:.2f} / {err[2]:.2f} | {statistics.fmean(o.duration for o in paths):.1f} / "
        f"{max(o.duration for o in paths):.1f} | {statistics.fmean(corners):.2f} / {max(corners):.2f} | "
        f"{statistics.fmean(sum(o.duration for o in sq) for sq in squares):.1f} | {failed}"
    )


CONDITIONS = (("default", 0.0), ("default", 0.005), ("default", 0.01), ("harsh", 0.01))  # (scenario, pose_sigma [m])


def report(seeds: int = 10, params: Params | None = None) -> str:
    """The benchmark tables (markdown): path trial and square per controller and condition, turn sweep."""
    base = params or Params()
    check_polar_gains(base.k_rho, base.k_alpha, base.k_beta)
    lines = [
        f"Path trial (0,0) -> (1,0) -> (1,1) and square (3 laps of 1 m), {seeds} seeds each, speed {base.speed} m/s, "
        f"tolerance {base.tolerance * 100:.1f} cm; errors are true position to goal; pose error = 1 sigma of the estimate's error",
        "",
        "| controller | scenario | pose error [cm] | path error mean / sd / max [cm] | path time mean / max [s] "
        "| square corner error mean / max [cm] | square time [s] | goals failed |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name, sigma in CONDITIONS:
        scenario = PRESETS[name]
        for ctrl in CONTROLLERS:
            row = compare(msgspec.structs.replace(base, controller=ctrl), scenario, seeds, sigma)
            lines.append(f"| {ctrl} | {name} | {sigma * 100:g} | {row} |")
    lines += [
        "",
        f"turn_to_heading from 0 at {base.turn_speed} rad/s, tolerance {math.degrees(base.heading_tolerance):.1f} deg, "
        f"`default` scenario, true pose, {seeds} seeds",
        "",
        "| target [deg] | final error mean / max [deg] | overshoot max [deg] | time mean [s] |",
        "|---|---|---|---|",
    ]
    sweeps = [turn_sweep(base, PRESETS["default"], s, HEADINGS) for s in range(seeds)]
    for i, deg in enumerate(HEADINGS):
        runs = [sw[i] for sw in sweeps]
        errs = [abs(math.degrees(wrap_angle(math.radians(deg) - o.theta))) for o in runs]
        lines.append(
            f"| {deg:g} | {statistics.fmean(errs):.2f} / {max(errs):.2f} | {max(math.degrees(o.overshoot) for o in runs):.2f} | "
            f"{statistics.fmean(o.duration for o in runs):.2f} |"
        )
    return "\n".join(lines)
