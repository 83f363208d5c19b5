"""Camera frames: to and from the `CameraFrame` message, and the sources that capture them.

Sources: the sim's frames arrive on the bus (`zenav/field/camera/frame`); `Capture`
reads a video file, a webcam (an index, "0") or an RTSP/HTTP URL through
cv2.VideoCapture and stamps each frame as close to its exposure as the source allows.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from zenav.common import messages as m
from zenav.common.config import Camera, ConfigError, Limits

if TYPE_CHECKING:
    import cv2

FRAME_OVERHEAD = 256  # [bytes] a CameraFrame's fields besides its pixels, at most


class FrameError(ValueError):
    """A frame that is corrupt or not the configured size."""


def check_fits(cfg: Camera, limits: Limits) -> None:
    """ConfigError unless a mono8 frame of the configured size fits in [limits] max_payload (larger ones are dropped unread)."""
    size = cfg.width * cfg.height + FRAME_OVERHEAD
    if size > limits.max_payload:
        raise ConfigError(f"a {cfg.width}x{cfg.height} frame is {size} bytes: raise [limits] max_payload ({limits.max_payload}) over it")


def encode(img: np.ndarray, t: float, seq: int, exposure: float = 0.0, encoding: str = "mono8") -> m.CameraFrame:
    """A grey image (H x W uint8) as a message; png and jpeg compress it (cost: a few ms)."""
    h, w = img.shape
    if encoding == "mono8":
        data = np.ascontiguousarray(img, dtype=np.uint8).tobytes()
    else:
        import cv2  # OpenCV (zenav[camera]) only for compressed frames and capture: a mono8 frame needs none

        ok, buf = cv2.imencode(".png" if encoding == "png" else ".jpg", img)
        if not ok:
            raise FrameError(f"cannot encode a {w}x{h} frame as {encoding}")
        data = buf.tobytes()
    return m.CameraFrame(t=t, seq=seq, width=w, height=h, encoding=encoding, exposure=exposure, data=data)  # type: ignore[arg-type]


def decode(frame: m.CameraFrame, width: int, height: int) -> np.ndarray:
    """The grey image of a frame (H x W uint8); FrameError when it is corrupt or not width x height [px]."""
    if (frame.width, frame.height) != (width, height):
        raise FrameError(f"frame is {frame.width}x{frame.height}, the camera is configured {width}x{height} ([camera] width, height)")
    if frame.encoding == "mono8":
        if len(frame.data) != width * height:
            raise FrameError(f"mono8 frame carries {len(frame.data)} bytes, {width}x{height} needs {width * height}")
        return np.frombuffer(frame.data, dtype=np.uint8).reshape(height, width)
    import cv2

    img = cv2.imdecode(np.frombuffer(frame.data, dtype=np.uint8), cv2.IMREAD_GRAYSCALE)
    if img is None:
        raise FrameError(f"{frame.encoding} frame does not decode")
    if img.shape != (height, width):
        raise FrameError(f"{frame.encoding} frame decodes to {img.shape[1]}x{img.shape[0]}, header says {width}x{height}")
    return img


@dataclass(frozen=True)
class Grabbed:
    """One captured frame."""

    t: float  # [s] capture time on the caller's clock
    img: np.ndarray  # H x W uint8


def open_capture(device: str) -> cv2.VideoCapture:
    """cv2.VideoCapture of a webcam index ("0"), a video file or a URL; FrameError when it does not open."""
    import cv2

    cap = cv2.VideoCapture(int(device) if device.isdigit() else device)
    if not cap.isOpened():
        raise FrameError(f"cannot open camera source {device!r} ([camera] device: a webcam index, a video file or a URL)")
    return cap


MAX_BUFFER_AGE = 1.0  # [s] a driver's buffer time older than this (or in the future) is not taken as the capture's


class Capture:
    """Frames from cv2.VideoCapture.

    A video file is stamped from its own timeline (start + the frame's position). A live
    source is stamped with the driver's buffer time when it gives one on the monotonic
    clock (V4L2 webcams do: the frame's capture, not its arrival), else with the moment
    grab() returned (after the transfer); either less `delay` [s] (half the exposure) to
    place it at the middle of the exposure.
    """

    def __init__(
        self,
        device: str,
        now: Callable[[], float] = time.time,
        start: float = 0.0,
        delay: float = 0.0,
        monotonic: Callable[[], float] = time.monotonic,
        cap: cv2.VideoCapture | None = None,  # an open source (tests); default: open `device`
    ) -> None:
        self.device, self.now, self.start, self.delay, self.monotonic = device, now, start, delay, monotonic
        self.cap = cap if cap is not None else open_capture(device)
        self.live = device.isdigit() or "://" in device

    def _stamp(self) -> float:
        import cv2

        position = self.cap.get(cv2.CAP_PROP_POS_MSEC) / 1000.0  # [s] a file's timeline; V4L2: the buffer's monotonic time
        if not self.live:
            return self.start + position
        age = self.monotonic() - position
        return self.now() - (age if 0.0 <= age < MAX_BUFFER_AGE else 0.0) - self.delay

    def read(self) -> Grabbed | None:
        """The next frame, grey; None at the end of a file or when the source fails."""
        if not self.cap.grab():
            return None
        t = self._stamp()
        ok, img = self.cap.retrieve()
        if not ok or img is None:
            return None
        if img.ndim == 3:
            import cv2

            img = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
        return Grabbed(t, img)

    def close(self) -> None:
        """Release the source."""
        self.cap.release()
