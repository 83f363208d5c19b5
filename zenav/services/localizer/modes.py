"""Every mode by its config name."""

from __future__ import annotations

from zenav.common.config import RobotConfig

from .base import LocalizerConfig, Mode
from .ekf import Ekf
from .estimate_average import EstimateAverage
from .simple import Complementary, DeadReckoning, Overwrite, SpeedWeighted, SpeedWeightedLatency


def make_mode(cfg: LocalizerConfig, robot: RobotConfig) -> Mode:
    """The mode cfg.mode names."""
    if cfg.mode in ("ekf", "ekf_no_delay"):
        return Ekf(cfg, robot, delayed=cfg.mode == "ekf")
    classes = {
        "dead_reckoning": DeadReckoning,
        "overwrite": Overwrite,
        "speed_weighted": SpeedWeighted,
        "speed_weighted_latency": SpeedWeightedLatency,
        "complementary": Complementary,
        "estimate_average": EstimateAverage,
    }
    return classes[cfg.mode](cfg, robot)
