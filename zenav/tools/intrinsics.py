"""A camera's intrinsics from views of a chessboard or a ChArUco board (OpenCV's calibrateCamera), and writing them
into a config file's camera section.

Pure but for OpenCV: images in, numbers out; `write_section` edits TOML text with config.set_keys (the config file's comments and other
sections are kept). A chessboard is given by its inner corners (cols x rows) and its squares' edge [m]; a ChArUco
board by its squares (cols x rows), their edge, its markers' edge and its ArUco dictionary.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from zenav.common.config import set_keys

MIN_VIEWS = 5  # views of the board a calibration needs at least
KEYS = ("width", "height", "fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3")


class IntrinsicsError(ValueError):
    """Too few usable views, or a board OpenCV cannot find."""


@dataclass(frozen=True)
class Board:
    """The calibration target."""

    kind: str  # "chessboard" or "charuco"
    cols: int  # chessboard: inner corners across; charuco: squares across
    rows: int
    square: float  # [m] edge of a square
    marker: float = 0.0  # [m] charuco: edge of a marker
    dictionary: str = "DICT_5X5_100"  # charuco: cv2.aruco's dictionary name

    def find(self, grey: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """(object points N x 3 [m], image points N x 2 [px]) of the board in a grey image, or None."""
        if self.kind == "chessboard":
            flags = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE
            ok, corners = cv2.findChessboardCorners(grey, (self.cols, self.rows), flags=flags)
            if not ok:
                return None
            crit = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_MAX_ITER, 30, 1e-3)
            corners = cv2.cornerSubPix(grey, corners, (5, 5), (-1, -1), crit)
            grid = np.mgrid[0 : self.cols, 0 : self.rows].T.reshape(-1, 2) * self.square
            return np.column_stack([grid, np.zeros(len(grid))]).astype(np.float32), corners.reshape(-1, 2)
        board = self.charuco()
        corners, ids, _, _ = cv2.aruco.CharucoDetector(board).detectBoard(grey)
        if ids is None or len(ids) < 6:  # fewer corners fit no pose reliably
            return None
        obj, img = board.matchImagePoints(corners, ids)
        return obj.reshape(-1, 3).astype(np.float32), img.reshape(-1, 2).astype(np.float32)

    def charuco(self) -> Any:
        """OpenCV's CharucoBoard of this board."""
        names = [n for n in dir(cv2.aruco) if n.startswith("DICT_")]
        if self.dictionary not in names:
            raise IntrinsicsError(f"no ArUco dictionary {self.dictionary!r} (OpenCV has {', '.join(sorted(names))})")
        dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, self.dictionary))
        return cv2.aruco.CharucoBoard((self.cols, self.rows), self.square, self.marker, dictionary)


@dataclass(frozen=True)
class Intrinsics:
    """A calibration's result, in [onboard_camera]'s and [camera]'s keys."""

    width: int  # [px]
    height: int  # [px]
    fx: float  # [px]
    fy: float
    cx: float
    cy: float
    k1: float
    k2: float
    p1: float
    p2: float
    k3: float
    rms: float  # [px] reprojection error over every corner
    views: int  # views of the board used

    def values(self) -> dict[str, float | int]:
        return {k: getattr(self, k) for k in KEYS}


def calibrate(images: Iterable[np.ndarray], board: Board, max_views: int = 40, fit_k3: bool = False) -> Intrinsics:
    """The intrinsics from the images (grey, all of one size) that show the board, up to `max_views` of them; k3 held
    at 0 unless `fit_k3` (OpenCV's advice but for wide lenses: a few views fit it to noise)."""
    obj, img, size = [], [], None
    for grey in images:
        if size is None:
            size = grey.shape[::-1]
        elif grey.shape[::-1] != size:
            raise IntrinsicsError(f"the views are of different sizes: {size} and {grey.shape[::-1]}")
        found = board.find(grey)
        if found is not None:
            obj.append(found[0])
            img.append(found[1])
        if len(obj) >= max_views:
            break
    if len(obj) < MIN_VIEWS:
        raise IntrinsicsError(f"the board was found in {len(obj)} views; a calibration needs {MIN_VIEWS} (tilt it, fill the frame)")
    assert size is not None
    rms, k, dist, _, _ = cv2.calibrateCamera(obj, img, size, None, None, flags=0 if fit_k3 else cv2.CALIB_FIX_K3)
    k1, k2, p1, p2, k3 = ([float(v) for v in np.ravel(dist)] + [0.0] * 5)[:5]
    return Intrinsics(
        int(size[0]), int(size[1]), float(k[0, 0]), float(k[1, 1]), float(k[0, 2]), float(k[1, 2]),
        k1, k2, p1, p2, k3, float(rms), len(obj),
    )  # fmt: skip


def write_section(text: str, section: str, values: dict[str, float | int]) -> str:
    """The TOML `text` with the intrinsics `values` (rounded to 9 decimals) set in [section], the rest kept."""
    return set_keys(text, section, {k: v if isinstance(v, int) else round(float(v), 9) for k, v in values.items()})
