"""AprilTag detection in a grey frame: pupil-apriltags (the default) or OpenCV's aruco.

Both return the same `Tag`: its id and its four corners in the frame's pixels (as
the lens saw them, not undistorted), in the printed tag's order: top-left,
top-right, bottom-right, bottom-left. The tag's right (top-left to top-right) is
the robot's forward.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, Protocol

import numpy as np

Backend = Literal["apriltag", "aruco"]
QUAD_SIGMA = 0.8  # [px] blur of the decimated image quads are looked for in: fewer noise edges (a third less time)


@dataclass(frozen=True)
class Tag:
    """One detected tag."""

    id: int
    corners: np.ndarray  # 4 x 2 [px]: top-left, top-right, bottom-right, bottom-left of the printed tag
    margin: float  # decoding confidence (pupil-apriltags' decision margin; aruco: 0)


class Detector(Protocol):
    """Finds tag36h11 tags in a grey image."""

    def detect(self, img: np.ndarray) -> list[Tag]: ...


class AprilTagDetector:
    """pupil-apriltags (the AprilTag 3 library): quads found on a decimated image, corners refined on the full one."""

    def __init__(self, decimate: float = 2.0, threads: int = 1) -> None:
        from pupil_apriltags import Detector as _Detector

        self._det = _Detector(
            families="tag36h11",
            nthreads=threads,
            quad_decimate=decimate,
            quad_sigma=QUAD_SIGMA if decimate > 1.0 else 0.0,
            refine_edges=True,
        )

    def __del__(self) -> None:
        """Free the detector, then its tag families (pupil-apriltags' own __del__ frees the families
        first, which the detector still uses: an intermittent segfault); its __del__ then does nothing."""
        det = getattr(self, "_det", None)
        ptr = getattr(det, "tag_detector_ptr", None)
        if det is None or ptr is None:
            return
        det.tag_detector_ptr = None
        det.libc.apriltag_detector_destroy.restype = None
        det.libc.apriltag_detector_destroy(ptr)
        for family, tf in det.tag_families.items():
            destroy = getattr(det.libc, f"{family}_destroy")
            destroy.restype = None
            destroy(tf)

    def detect(self, img: np.ndarray) -> list[Tag]:
        """Tags in `img` (H x W uint8)."""
        out = []
        for d in self._det.detect(np.ascontiguousarray(img)):
            # The library wraps the corners counter-clockwise (y up) from the tag's top-right, as seen here.
            c = np.asarray(d.corners, dtype=np.float64)
            out.append(Tag(int(d.tag_id), c[[1, 0, 3, 2]], float(d.decision_margin)))
        return out


class ArucoDetector:
    """OpenCV's aruco module with its tag36h11 dictionary and AprilTag corner refinement."""

    def __init__(self) -> None:
        import cv2

        aruco = cv2.aruco
        params = aruco.DetectorParameters()
        params.cornerRefinementMethod = aruco.CORNER_REFINE_SUBPIX
        self._det = aruco.ArucoDetector(aruco.getPredefinedDictionary(aruco.DICT_APRILTAG_36h11), params)

    def detect(self, img: np.ndarray) -> list[Tag]:
        """Tags in `img` (H x W uint8)."""
        corners, ids, _ = self._det.detectMarkers(img)
        if ids is None:
            return []
        return [Tag(int(i), np.asarray(c, dtype=np.float64).reshape(4, 2), 0.0) for c, i in zip(corners, ids.ravel())]


def decimation(tag_px: float) -> float:
    """pupil-apriltags' quad_decimate for tags of this edge [px]: 2 (4x faster) when a tag stays over 12 px decimated."""
    return 2.0 if tag_px >= 24.0 else 1.0


def make(backend: Backend = "apriltag", tag_px: float = 24.0) -> Detector:
    """The detector of a backend for tags of about `tag_px` [px] edge; ImportError names the missing package."""
    return AprilTagDetector(decimation(tag_px)) if backend == "apriltag" else ArucoDetector()
