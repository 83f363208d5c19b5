"""The calibration study: the localizer's online wheel and track-width estimates against the scenario's truth.

    zenav bench studies calibration --seeds 5 --scenarios default coarse harsh

The robot drives the 1 m square for 60 s on the world model (harness.py: the scenario's
wheels, slip, encoders, gyro and VPS camera); the default localizer is fed its streams
(localizer.py's `evaluate`) and its estimates read at the end, as `zenav calibrate
--from-localizer` reads them from a running localizer. Prints each estimate's mean over
the seeds, the truth, the largest error of any seed [%], against the goal (0.5 %), and the
filter's own 1-sigma of it [%] (the mean over the seeds): an error well within the goal
needs a sigma well within it.
"""

from __future__ import annotations

import statistics
from collections.abc import Sequence

from zenav.bench.studies.localizer import drive_square, evaluate
from zenav.common.config import RobotConfig
from zenav.common.scenarios import Scenario, scenario
from zenav.services.localizer.base import LocalizerConfig
from zenav.services.localizer.modes import make_mode

GOAL = 0.005  # relative error of each estimate after 60 s, at most
KEYS = ("distance_scale", "track_width_scale", "wheel_radius_ratio")


def truth(sc: Scenario) -> dict[str, float]:
    """The scenario's true calibration in the localizer's terms (true / nominal; left / right)."""
    left, right = 1.0 + sc.wheel_radius_err_left, 1.0 + sc.wheel_radius_err_right
    return {
        "distance_scale": (left + right) / 2.0 + sc.load_radius_err,
        "track_width_scale": 1.0 + sc.track_width_err,
        "wheel_radius_ratio": left / right,
    }


def estimates(name: str, seed: int, duration: float = 60.0) -> dict[str, float]:
    """The default localizer's calibration after `duration` [s] of the scenario's square."""
    sc = scenario(name)
    robot = RobotConfig(ticks_per_rev=sc.ticks_per_rev)
    r = drive_square(sc, seed, duration)
    loc = make_mode(LocalizerConfig(), robot)
    evaluate(loc, r.odom, r.fixes, r.truth, r.imu, r.compass)
    return loc.calibration()


def table(scenarios: Sequence[str], seeds: Sequence[int], duration: float = 60.0) -> str:
    """The markdown table: each estimate's mean, the truth, the worst seed's error, the goal met."""
    lines = [
        f"| scenario | estimate | mean of {len(seeds)} seeds | truth | worst error % | within {GOAL * 100:g} % | filter's sigma % |",
        "|---|---|---|---|---|---|---|",
    ]
    for name in scenarios:
        true = truth(scenario(name))
        runs = [estimates(name, seed, duration) for seed in seeds]
        for key in KEYS:
            values = [r[key] for r in runs]
            worst = max(abs(v / true[key] - 1.0) for v in values)
            met = "yes" if worst <= GOAL else "**no**"
            sigma = statistics.fmean(r[f"{key}_sigma"] for r in runs)
            mean = statistics.fmean(values)
            lines.append(f"| {name} | {key} | {mean:.4f} | {true[key]:.4f} | {worst * 100:.2f} | {met} | {sigma * 100:.2f} |")
    return "\n".join(lines)
