"""AprilTag (tag36h11) detection in a grey frame: the AprilTag library (pupil-apriltags) or OpenCV alone.

Both backends return the same `Tag`: its id and its four corners in the frame's pixels
(as the lens saw them, not undistorted; pixel centres at whole numbers, OpenCV's
convention, where the AprilTag library puts them at halves), in the printed tag's order:
top-left, top-right, bottom-right, bottom-left. The tag's right (top-left to top-right)
is the robot's forward.

Both find the tags' outlines with the AprilTag library's quad detector (OpenCV carries a
port of it): on the frame halved when the tags are large enough (`decimation`), else on
the full frame. The OpenCV backend then reads and refines each outline itself
(outline.py: OpenCV's own decoding loses most tags under ~20 px). `make` picks the
backend ("auto": the AprilTag library when it is installed, else OpenCV's) and the
settings for the tags' size in pixels.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, Protocol

import numpy as np

from zenav.common import extras
from zenav.services.vps import outline

Backend = Literal["auto", "apriltag", "opencv"]
BACKENDS: tuple[str, ...] = ("auto", "apriltag", "opencv")
QUAD_SIGMA = 0.8  # [px] blur of the decimated image quads are looked for in: fewer noise edges (a third less time)
SMALL_TAG_PX = 24.0  # [px] tags at least this large are looked for on the frame halved (4 times less work)
TINY_TAG_PX = 16.0  # [px] under this (2 px a cell) the AprilTag library misreads tags: it reads the frame enlarged
ENLARGE = 1.5  # how much (on two real photos of 10 to 20 px tags: 24 of 25 read, 22 without; 1.25 to 1.75 alike)
HALF_PIXEL = 0.5  # [px] the AprilTag library's pixel centres, less OpenCV's


@dataclass(frozen=True)
class Tag:
    """One detected tag."""

    id: int
    corners: np.ndarray  # 4 x 2 [px]: top-left, top-right, bottom-right, bottom-left of the printed tag
    margin: float  # [grey levels] decision margin: how far the least clear code cell is from the threshold


class Detector(Protocol):
    """Finds tag36h11 tags in a grey image."""

    def detect(self, img: np.ndarray) -> list[Tag]: ...


def decimation(tag_px: float) -> float:
    """How much the frame is shrunk to look for tags whose smallest edge is `tag_px` [px]: 2 when they stay over 12 px."""
    return 2.0 if tag_px >= SMALL_TAG_PX else 1.0


def enlargement(tag_px: float) -> float:
    """How much the AprilTag library's frame is enlarged for tags whose smallest edge is `tag_px` [px]."""
    return ENLARGE if tag_px < TINY_TAG_PX else 1.0


class AprilTagDetector:
    """pupil-apriltags (the AprilTag 3 library): quads found on a decimated image, corners refined on the full one;
    or on the frame enlarged `enlarge` times (cubic), for tiny tags."""

    def __init__(self, decimate: float = 2.0, enlarge: float = 1.0, threads: int = 1) -> None:
        lib = extras.require("pupil_apriltags", "the AprilTag detector")
        self.enlarge = enlarge
        self._cv2 = extras.require("cv2", "the camera") if enlarge != 1.0 else None
        self._det = lib.Detector(
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
        k = self.enlarge
        if self._cv2 is not None:
            img = self._cv2.resize(img, None, fx=k, fy=k, interpolation=self._cv2.INTER_CUBIC)
        out = []
        for d in self._det.detect(np.ascontiguousarray(img)):
            # The library wraps the corners counter-clockwise (y up) from the tag's top-right, as seen here.
            c = np.asarray(d.corners, dtype=np.float64) / k - HALF_PIXEL  # its pixel i spans [i, i + 1)
            out.append(Tag(int(d.tag_id), c[[1, 0, 3, 2]], float(d.decision_margin)))
        return out


class OpenCVDetector:
    """OpenCV alone: its port of the AprilTag quad detector finds the outlines, outline.py reads and refines them."""

    def __init__(self, decimate: float = 2.0) -> None:
        cv2 = extras.require("cv2", "the camera")
        self.reach = decimate + 1.0  # [px] how far an outline may be off the image's edge (the AprilTag library's)
        self._cv2, aruco = cv2, cv2.aruco
        params = aruco.DetectorParameters()
        params.cornerRefinementMethod = aruco.CORNER_REFINE_APRILTAG  # the AprilTag quad detector finds the candidates
        params.aprilTagQuadDecimate = decimate
        params.aprilTagQuadSigma = QUAD_SIGMA if decimate > 1.0 else 0.0
        self.dictionary = aruco.getPredefinedDictionary(aruco.DICT_APRILTAG_36h11)
        self._det = aruco.ArucoDetector(self.dictionary, params)

    def detect(self, img: np.ndarray) -> list[Tag]:
        """Tags in `img` (H x W uint8)."""
        accepted, _, rejected = self._det.detectMarkers(img)
        # Every outline, whether OpenCV's decoding took it or not, read again (outline.py says why).
        quads = np.array([np.asarray(q, dtype=np.float64).reshape(4, 2) for q in (*accepted, *rejected)]).reshape(-1, 4, 2) - HALF_PIXEL
        out = []
        for i, tag_id, rotation, margin in outline.read(self._cv2, img, quads, self.dictionary):
            corners = outline.refine(self._cv2, img, np.roll(quads[i], rotation, axis=0), self.reach)
            out.append(Tag(tag_id, corners, margin))
        return unique(out)


def unique(tags: list[Tag]) -> list[Tag]:
    """The tags, each outline once (a quad may be found twice, OpenCV taking one and leaving the other)."""
    out: list[Tag] = []
    for t in sorted(tags, key=lambda t: -t.margin):
        centre = t.corners.mean(axis=0)
        if all(s.id != t.id or np.linalg.norm(s.corners.mean(axis=0) - centre) > 1.0 for s in out):
            out.append(t)
    return out


def resolve(backend: Backend) -> Literal["apriltag", "opencv"]:
    """The backend `auto` means here: the AprilTag library when it is installed, else OpenCV's."""
    if backend == "auto":
        return "apriltag" if extras.installed("pupil_apriltags") else "opencv"
    return backend


def make(backend: Backend = "auto", tag_px: float = SMALL_TAG_PX) -> Detector:
    """The detector of a backend for tags whose smallest edge is about `tag_px` [px]; MissingExtra names a missing package."""
    if resolve(backend) == "apriltag":
        return AprilTagDetector(decimation(tag_px), enlargement(tag_px))
    return OpenCVDetector(decimation(tag_px))
