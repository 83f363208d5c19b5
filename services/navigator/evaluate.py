"""Measuring the navigator alone: its goal machine driving a kinematic robot with the
scenario's motor lag, deadband, saturation, wheel slip and wheel/track errors.

The pose it is given is the truth plus an optional localizer-like error (a random
walk that jumps at the VPS rate, as fixes correct the estimate), with the speeds
measured from quantised encoder ticks.
Everything is seeded; `report()` gives the tables of the README:
`python -m zenav.services.navigator.evaluate`.
"""
from __future__ import annotations

import math
import random
import statistics
from dataclasses import dataclass
from typing import Optional, Sequence

import msgspec

from zenav.common.config import Robot
from zenav.common.geometry import wrap_angle
from zenav.common.scenarios import PRESETS, Scenario
from zenav.services.navigator.controllers import PoseSample, Wheelbase, check_polar_gains
from zenav.services.navigator.goals import FOLLOWING_PATH, MOVING_TO_POINT, TURNING_TO_HEADING, Goal, GoalMachine
from zenav.services.navigator.params import CONTROLLERS, Params

DT = 0.01  # [s] step of the world and rate of the pose (the sensors' 100 Hz)
PATH = ((1.0, 0.0), (1.0, 1.0))  # seed 002's path trial, from (0, 0, 0)
SQUARE = ((1.0, 0.0), (1.0, 1.0), (0.0, 1.0), (0.0, 0.0))  # seed 003's square, one lap


class KinematicRobot:
    """A differential-drive robot whose true geometry and motors differ from nominal."""

    def __init__(self, robot: Robot, scenario: Scenario, seed: int, pose_sigma: float = 0.0) -> None:
        self.robot, self.s, self.rng = robot, scenario, random.Random(seed)
        self.x, self.y, self.theta = 0.0, 0.0, 0.0
        self.pose_sigma = pose_sigma  # [m] 1 sigma of the estimate's error (heading: pose_sigma / 0.3 m)
        self.err = (0.0, 0.0, 0.0)  # (x [m], y [m], theta [rad]) error of the estimate now
        self._since_fix = 0.0  # [s]
        self.w = [0.0, 0.0]  # [rad/s] actual wheel speeds, left and right
        self.angle = [0.0, 0.0]  # [rad] wheel angles, for the encoders
        self.ticks = [0, 0]

    def wheel_commands(self, v: float, omega: float) -> list[float]:
        """Wheel speed commands [rad/s] as the motor service computes them (nominal geometry)."""
        half, r = self.robot.track_width / 2.0, self.robot.wheel_radius
        return [(v - omega * half) / r, (v + omega * half) / r]

    def step(self, v: float, omega: float, dt: float) -> tuple[float, float]:
        """Advance by dt under the command; return (v, omega) measured from the encoder ticks."""
        s, r = self.s, self.robot.wheel_radius
        radius = (r * (1 + s.wheel_radius_err_left + s.load_radius_err), r * (1 + s.wheel_radius_err_right + s.load_radius_err))
        gain = 1.0 - math.exp(-dt / s.motor_lag) if s.motor_lag > 0 else 1.0
        travel, old_ticks = [], list(self.ticks)
        for i, cmd in enumerate(self.wheel_commands(v, omega)):
            cmd = 0.0 if abs(cmd) < s.motor_deadband else max(-s.motor_max, min(s.motor_max, cmd))
            self.w[i] += (cmd - self.w[i]) * gain
            self.angle[i] += self.w[i] * dt
            self.ticks[i] = math.floor(self.angle[i] / (2 * math.pi) * self.robot.ticks_per_rev)
            travel.append(self.w[i] * dt * radius[i] * (1.0 + self.rng.gauss(0.0, s.slip_sigma)))
        ds, dth = (travel[0] + travel[1]) / 2.0, (travel[1] - travel[0]) / (self.robot.track_width * (1 + s.track_width_err))
        self.x += ds * math.cos(self.theta + dth / 2.0)
        self.y += ds * math.sin(self.theta + dth / 2.0)
        self.theta = wrap_angle(self.theta + dth)
        self._since_fix += dt
        if self.pose_sigma > 0 and self._since_fix >= 1.0 / s.vps_rate_hz:
            self._since_fix, keep = 0.0, 0.8  # AR(1): each fix pulls the error and adds a new one
            sig = (self.pose_sigma, self.pose_sigma, self.pose_sigma / 0.3)
            self.err = tuple(keep * e + self.rng.gauss(0.0, g * math.sqrt(1 - keep**2)) for e, g in zip(self.err, sig))
        per_tick = 2 * math.pi / self.robot.ticks_per_rev * r  # [m] nominal travel of one tick
        dl, dr = ((self.ticks[i] - old_ticks[i]) * per_tick for i in (0, 1))
        return (dl + dr) / (2.0 * dt), (dr - dl) / (self.robot.track_width * dt)

    def estimate(self, t: float, v: float = 0.0, omega: float = 0.0) -> PoseSample:
        """The pose as the localizer would give it: truth plus the current error."""
        ex, ey, eth = self.err
        return PoseSample(t, self.x + ex, self.y + ey, wrap_angle(self.theta + eth), v, omega)


@dataclass(frozen=True)
class Outcome:
    """One goal driven to its end on the kinematic robot."""

    result: str
    message: str
    duration: float  # [s]
    x: float  # [m] true position at the end
    y: float
    theta: float  # [rad]
    overshoot: float  # [rad] turns: furthest the true heading went past the target


def drive(robot: KinematicRobot, machine: GoalMachine, goal: Goal, t0: float, timeout: float = 120.0) -> Outcome:
    """Run one goal to its end; the command acts from the next step (one pose of latency)."""
    machine.on_pose(robot.estimate(t0))
    machine.start(goal, t0)
    t, cmd, v_meas, w_meas, overshoot, end = t0, (0.0, 0.0), 0.0, 0.0, 0.0, None
    side = math.copysign(1.0, wrap_angle(goal.heading - robot.theta))
    steps = 0
    while end is None and t - t0 < timeout:
        v_meas, w_meas = robot.step(*cmd, DT)
        t += DT
        steps += 1
        new, end = machine.on_pose(robot.estimate(t, v_meas, w_meas))
        cmd = new or (0.0, 0.0)
        if end is None and steps % round(machine.params.check_period / DT) == 0:
            end = machine.check(t)
        if goal.state == TURNING_TO_HEADING:
            overshoot = max(overshoot, -side * wrap_angle(goal.heading - robot.theta))
    for _ in range(round(0.5 / DT)):  # let the robot come to rest before measuring it
        robot.step(0.0, 0.0, DT)
    result, message = (end.result, end.message) if end else ("timeout", "")
    return Outcome(result, message, t - t0, robot.x, robot.y, robot.theta, overshoot)


def _robot(scenario: Scenario) -> Robot:
    """The nominal robot, with the scenario's encoders."""
    return Robot(ticks_per_rev=scenario.ticks_per_rev)


def _machine(params: Params, robot: Robot) -> GoalMachine:
    return GoalMachine(params, Wheelbase(robot.track_width, robot.wheel_radius, robot.max_wheel_speed))


def path_trial(params: Params, scenario: Scenario, seed: int, pose_sigma: float = 0.0) -> Outcome:
    """Seed 002's trial: from (0, 0, 0) follow (1, 0) -> (1, 1)."""
    goal = Goal(FOLLOWING_PATH, points=PATH, speed=params.speed, tolerance=params.tolerance)
    robot = _robot(scenario)
    return drive(KinematicRobot(robot, scenario, seed, pose_sigma), _machine(params, robot), goal, 0.0)


def square_trial(params: Params, scenario: Scenario, seed: int, pose_sigma: float = 0.0, laps: int = 3) -> list[Outcome]:
    """Seed 003's square: move_to_point around a 1 m square and back to the start, `laps` times."""
    robot = _robot(scenario)
    body, machine, t, out = KinematicRobot(robot, scenario, seed, pose_sigma), _machine(params, robot), 0.0, []
    for x, y in SQUARE * laps:
        out.append(drive(body, machine, Goal(MOVING_TO_POINT, points=((x, y),), speed=params.speed, tolerance=params.tolerance), t))
        t += out[-1].duration + 0.5
    return out


def turn_sweep(params: Params, scenario: Scenario, seed: int, headings_deg: Sequence[float], pose_sigma: float = 0.0) -> list[Outcome]:
    """turn_to_heading from 0 to each heading (each from a fresh robot at rest)."""
    robot, out = _robot(scenario), []
    for i, deg in enumerate(headings_deg):
        goal = Goal(TURNING_TO_HEADING, heading=math.radians(deg), speed=params.turn_speed, tolerance=params.heading_tolerance)
        body = KinematicRobot(robot, scenario, seed * 1000 + i, pose_sigma)
        out.append(drive(body, _machine(params, robot), goal, 0.0))
    return out


def stats(values: Sequence[float]) -> tuple[float, float, float]:
    """Mean, sample standard deviation and max."""
    return statistics.fmean(values), statistics.stdev(values) if len(values) > 1 else 0.0, max(values)


def compare(params: Params, scenario: Scenario, seeds: int, pose_sigma: float = 0.0) -> str:
    """One table row: path trial and square of one controller, as markdown cells."""
    paths = [path_trial(params, scenario, s, pose_sigma) for s in range(seeds)]
    squares = [square_trial(params, scenario, s, pose_sigma) for s in range(seeds)]
    err = stats([100 * math.dist((o.x, o.y), PATH[-1]) for o in paths])
    corners = [100 * math.dist((o.x, o.y), c) for sq in squares for o, c in zip(sq, SQUARE * 3)]
    failed = sum(o.result != "succeeded" for o in paths + [o for sq in squares for o in sq])
    return (
        f"{err[0]:.2f} / {err[1]:.2f} / {err[2]:.2f} | {statistics.fmean(o.duration for o in paths):.1f} / "
        f"{max(o.duration for o in paths):.1f} | {statistics.fmean(corners):.2f} / {max(corners):.2f} | "
        f"{statistics.fmean(sum(o.duration for o in sq) for sq in squares):.1f} | {failed}"
    )


CONDITIONS = (("default", 0.0), ("default", 0.005), ("default", 0.01), ("harsh", 0.01))  # (scenario, pose_sigma [m])
HEADINGS = (5.0, 30.0, 90.0, -90.0, 180.0, -135.0)  # [deg] turn sweep targets


def report(seeds: int = 10, params: Optional[Params] = None) -> str:
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


if __name__ == "__main__":
    print(report())
