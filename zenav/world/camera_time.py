"""The camera's times: its host's clock off the stack's, and a rolling shutter's rows.

Pure; shared by the sim, which plays the camera, and the vps, which undoes what it can.
"""

from __future__ import annotations

from typing import Any


def host_time(t: float, offset: float, drift_ppm: float) -> float:
    """[s] a clock `offset` [s] ahead and `drift_ppm` fast of one that reads t [s]."""
    return t + offset + drift_ppm * 1e-6 * t


def row_time(row: Any, height: int, readout: float) -> Any:
    """[s] when pixel row `row` (a number or an array) was exposed, after the frame's stamp (the middle row's)."""
    return ((row + 0.5) / height - 0.5) * readout
