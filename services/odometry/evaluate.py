"""How far dead reckoning drifts: each heading source on the sim's own physics and sensors.

    python -m zenav.services.odometry.evaluate [--seeds 10] [--scenarios default coarse harsh]

Drives 3 laps of a 1 m square (straight at 0.2 m/s, turns in place at 1 rad/s) with
open-loop wheel commands through services/sim's physics and sensors, feeds the samples
to the odometry's state machine, and reports the final position error and the largest
heading jump in odom (a heading change the true motion does not explain).
"""
from __future__ import annotations

import argparse
import math
from typing import NamedTuple

import numpy as np

from zenav.common.config import Settings
from zenav.common.geometry import wrap_angle
from zenav.services.odometry import odometry as od
from zenav.services.odometry.service import OdometryConfig, params
from zenav.services.sim import physics, sensors

DT = 0.01  # [s] 100 Hz
SPEED, TURN_RATE = 0.2, 1.0  # [m/s], [rad/s]
COMPASS_EVERY = 10  # steps: 10 Hz


def square(robot, laps: int = 3) -> list[tuple[float, float, float]]:
    """Segments (duration [s], left, right wheel command [rad/s]) of `laps` 1 m squares."""
    r, half = robot.wheel_radius, robot.track_width / 2.0
    drive, turn = SPEED / r, TURN_RATE * half / r
    segs = [(1.0, 0.0, 0.0)]  # standing still first: the gyro and compass settle
    for _ in range(laps * 4):
        segs += [(1.0 / SPEED, drive, drive), (0.2, 0.0, 0.0), ((math.pi / 2) / TURN_RATE, -turn, turn), (0.2, 0.0, 0.0)]
    return segs


def run(settings: Settings, cfg: OdometryConfig, seed: int) -> tuple[float, float]:
    """(final position error [m], largest unexplained heading step [rad]) of one drive."""
    scen, rng = settings.scenario, np.random.default_rng(seed)
    w, p = physics.world(settings.robot, scen), params(settings.robot, cfg)
    s, o_state = physics.State(), od.OdometryState()
    step, odom, prev, jump = 0, None, None, 0.0
    for duration, left, right in square(settings.robot):
        for _ in range(round(duration / DT)):
            s = physics.step(s, w, left, right, DT, rng)
            step += 1
            t = step * DT
            gyro_z, _, accel_y = sensors.imu(s, scen, rng)
            o_state, _ = od.on_imu(o_state, p, t, gyro_z, accel_y)
            if step % COMPASS_EVERY == 0:
                o_state, _ = od.on_compass(o_state, t, sensors.compass(s, scen, rng))
            ticks = (sensors.encoder_ticks(s.angle_left, scen.ticks_per_rev), sensors.encoder_ticks(s.angle_right, scen.ticks_per_rev))
            o_state, out, _ = od.update(o_state, p, *ticks, t)
            if out is not None:
                if prev is not None:
                    jump = max(jump, abs(wrap_angle((out.theta - prev[0]) - (s.theta - prev[1]))))
                odom, prev = out, (out.theta, s.theta)
    return math.hypot(odom.x - s.x, odom.y - s.y), jump


class Row(NamedTuple):
    scenario: str
    label: str
    final_cm: float
    jump_deg: float


CONFIGS = [
    ("encoders", dict(heading_source="encoders")),
    ("gyro", dict(heading_source="gyro")),
    ("compass, gain 1 (replace)", dict(heading_source="compass", compass_gain=1.0)),
    ("compass, gain 0.1 (default)", dict(heading_source="compass")),
    ("blend 1:3:0", dict(heading_source="blend", blend_encoders=1.0, blend_gyro=3.0, blend_accel=0.0)),
]


def evaluate(scenarios: list[str], seeds: int) -> list[Row]:
    rows = []
    for name in scenarios:
        settings = Settings.load(None, deployment={"scenario": name})
        for label, overrides in CONFIGS:
            cfg = Settings.load(None, odometry=overrides).section("odometry", OdometryConfig)
            results = [run(settings, cfg, seed) for seed in range(1, seeds + 1)]
            rows.append(Row(name, label, 100 * np.mean([r[0] for r in results]), math.degrees(np.mean([r[1] for r in results]))))
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--scenarios", nargs="+", default=["default", "coarse", "harsh"])
    args = ap.parse_args()
    print(f"3 laps of a 1 m square, mean of {args.seeds} seeds, arc integrator")
    print("| scenario | heading source | final error [cm] | largest heading jump in odom [deg] |")
    print("|---|---|---|---|")
    for r in evaluate(args.scenarios, args.seeds):
        print(f"| {r.scenario} | {r.label} | {r.final_cm:.1f} | {r.jump_deg:.1f} |")


if __name__ == "__main__":
    main()
