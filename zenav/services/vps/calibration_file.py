"""The camera calibration file: written by `zenav camera calibrate`, read by the camera vps and `zenav camera snapshot`.

The file's I/O, kept out of the pure calibration maths (calibration.py)."""

from __future__ import annotations

import json
from pathlib import Path

from zenav.common.config import AUTO_CALIBRATION, Camera
from zenav.services.vps.calibration import Calibration, CalibrationError


def save(cal: Calibration, path: str | Path) -> None:
    """Write the calibration file."""
    Path(path).write_text(json.dumps(cal.to_json(), indent=2) + "\n")


def load(path: str | Path) -> Calibration:
    """Read a calibration file; CalibrationError says what to run when there is none."""
    p = Path(path)
    if not p.is_file():
        raise CalibrationError(f"no camera calibration at {p}: run `zenav camera calibrate` (it writes [camera] calibration)")
    try:
        return Calibration.from_json(json.loads(p.read_text()))
    except (OSError, ValueError, KeyError, TypeError) as e:
        raise CalibrationError(f"camera calibration {p} is unreadable ({e}): run `zenav camera calibrate` again") from None


def configured(cfg: Camera) -> Calibration | None:
    """The calibration file [camera] names; None when it says "auto" (fit one to the frames' fixed tags)."""
    return None if cfg.calibration == AUTO_CALIBRATION else load(cfg.calibration)
