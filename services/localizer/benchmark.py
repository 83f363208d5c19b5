"""The localizer benchmark on the synthetic world: every mode on the same seeds, side by side.

    python -m zenav.services.localizer.benchmark --seeds 5 --scenarios default harsh

Prints a markdown table of position RMSE, max, final and outage-end error [cm],
heading RMSE [deg] and outliers accepted, averaged over the seeds, for the robot
driving the 1 m square at 0.3 m/s for 60 s.
"""
from __future__ import annotations

import argparse
import math
import statistics
from typing import Optional, Sequence

from zenav.common.config import Robot
from zenav.common.scenarios import scenario

from .base import MODES, LocalizerConfig
from .evaluate import Score, evaluate
from .modes import make_mode
from .synthetic import drive_square


def run(scenario_name: str, mode: str, seeds: Sequence[int], imu: bool = True) -> list[Score]:
    """Scores of one mode on one scenario, one per seed."""
    sc = scenario(scenario_name)
    robot = Robot(ticks_per_rev=sc.ticks_per_rev)
    outage = None
    if sc.vps_outage_start is not None:
        outage = (sc.vps_outage_start, sc.vps_outage_start + sc.vps_outage_duration)
    out = []
    for seed in seeds:
        r = drive_square(sc, seed)
        loc = make_mode(LocalizerConfig(mode=mode), robot)
        out.append(
            evaluate(loc, r.odom, r.fixes, r.truth, r.imu if imu else (), r.compass if imu else (), outage=outage)
        )
    return out


def _mean(scores: list[Score], field: str, scale: float) -> str:
    values = [getattr(s, field) for s in scores if getattr(s, field) is not None]
    return f"{scale * statistics.fmean(values):.2f}" if values else "-"


def table(scenarios: Sequence[str], modes: Sequence[str], seeds: Sequence[int], imu: bool = True) -> str:
    """The markdown table of every mode on every scenario."""
    lines = [
        "| scenario | mode | RMSE cm | max cm | final cm | outage end cm | heading RMSE deg | outliers accepted |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name in scenarios:
        for mode in modes:
            sc = run(name, mode, seeds, imu)
            cells = [
                _mean(sc, "rmse", 100),
                _mean(sc, "max", 100),
                _mean(sc, "final", 100),
                _mean(sc, "outage_end", 100),
                _mean(sc, "heading_rmse", 180 / math.pi),
                str(sum(s.outliers_accepted for s in sc)),
            ]
            lines.append(f"| {name} | {mode} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv: Optional[Sequence[str]] = None) -> int:
    parser = argparse.ArgumentParser(prog="zenav-localizer-benchmark", description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5, help="seeds 1..N (default 5)")
    parser.add_argument("--scenarios", nargs="+", default=["default", "harsh"])
    parser.add_argument("--modes", nargs="+", default=list(MODES), choices=MODES)
    parser.add_argument("--no-imu", action="store_true", help="withhold the IMU and compass streams")
    args = parser.parse_args(argv)
    print(table(args.scenarios, args.modes, range(1, args.seeds + 1), imu=not args.no_imu))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
