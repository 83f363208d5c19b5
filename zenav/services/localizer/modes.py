"""Every mode by its config name."""

from __future__ import annotations

from zenav.common.config import Robot

from .base import LocalizerConfig, Mode
from .ekf import Ekf
from .seed001 import Seed001
from .simple import DeadReckoning, MultiSensor, Overwrite, Weighted, WeightedLatency


def make_mode(cfg: LocalizerConfig, robot: Robot) -> Mode:
    """The mode cfg.mode names."""
    if cfg.mode in ("ekf", "ekf_no_delay"):
        return Ekf(cfg, robot, delayed=cfg.mode == "ekf")
    classes = {
        "dead_reckoning": DeadReckoning,
        "overwrite": Overwrite,
        "weighted": Weighted,
        "weighted_latency": WeightedLatency,
        "multisensor": MultiSensor,
        "seed001": Seed001,
    }
    return classes[cfg.mode](cfg, robot)
