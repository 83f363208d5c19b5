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
    """The grey image of a frame (H x W uint8); FrameError when it is corrupt or not width x height [px].

    A png or jpeg frame's size is read from its own header before anything is decoded: a
    small file may decode to gigabytes of pixels, so one that is not the camera's size is refused unread."""
    if (frame.width, frame.height) != (width, height):
        raise FrameError(f"frame is {frame.width}x{frame.height}, the camera is configured {width}x{height} ([camera] width, height)")
    if frame.encoding == "mono8":
        if len(frame.data) != width * height:
            raise FrameError(f"mono8 frame carries {len(frame.data)} bytes, {width}x{height} needs {width * height}")
        return np.frombuffer(frame.data, dtype=np.uint8).reshape(height, width)
    size = png_size(frame.data) if frame.encoding == "png" else jpeg_size(frame.data)
    if size is None:
        raise FrameError(f"{frame.encoding} frame has no readable {frame.encoding} header")
    if size != (width, height):
        raise FrameError(f"{frame.encoding} header says {size[0]}x{size[1]}, the camera is configured {width}x{height}: not decoded")
    import cv2

    img = cv2.imdecode(np.frombuffer(frame.data, dtype=np.uint8), cv2.IMREAD_GRAYSCALE)
    if img is None:
        raise FrameError(f"{frame.encoding} frame does not decode")
    if img.shape != (height, width):
        raise FrameError(f"{frame.encoding} frame decodes to {img.shape[1]}x{img.shape[0]}, its header says {width}x{height}")
    return img


PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
# JPEG start-of-frame markers (baseline, progressive, lossless, arithmetic...): their segment holds the size
JPEG_SOF = frozenset({0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF})
JPEG_STANDALONE = frozenset({0x01, *range(0xD0, 0xD8)})  # markers without a length: TEM, RSTn


def png_size(data: bytes) -> tuple[int, int] | None:
    """(width, height) [px] from a PNG's IHDR chunk, which must come first; None: no PNG header."""
    if len(data) < 24 or data[:8] != PNG_SIGNATURE or data[12:16] != b"IHDR":
        return None
    return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")


def jpeg_size(data: bytes) -> tuple[int, int] | None:
    """(width, height) [px] from a JPEG's start-of-frame segment, walking the segments before it; None: none found."""
    if data[:2] != b"\xff\xd8":
        return None
    i = 2
    while i + 4 <= len(data):  # each step moves past one marker and its segment: bounded by the length
        if data[i] != 0xFF:
            return None
        marker = data[i + 1]
        if marker == 0xFF:  # fill byte
            i += 1
            continue
        if marker in JPEG_STANDALONE:
            i += 2
            continue
        if marker in (0xD9, 0xDA):  # end of image, or the scan began, before any frame header
            return None
        length = int.from_bytes(data[i + 2 : i + 4], "big")
        if length < 2:
            return None
        if marker in JPEG_SOF:
            if i + 9 > len(data) or length < 7:
                return None
            return int.from_bytes(data[i + 7 : i + 9], "big"), int.from_bytes(data[i + 5 : i + 7], "big")
        i += 2 + length
    return None


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
