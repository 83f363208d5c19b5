"""The overhead camera's frames as sensor_msgs/Image, with their sensor_msgs/CameraInfo (`zenav ros2 --image`).

Frames come on the field's `camera/frame` topic (CameraFrame: mono8, PNG or JPEG bytes with
their stamp; the sim's camera, `zenav camera stream`). Each is decoded (vps/frames.py: OpenCV,
a frame not of [camera] width x height refused unread) to an Image `mono8` (zenav's frames
are grey) on `camera/image_raw`, and a CameraInfo of the [camera] intrinsics (`plumb_bob`:
k1, k2, p1, p2, k3) with the same header on `camera/camera_info`, frame `camera`.

Bounded: the Zenoh callback keeps only the newest frame (one slot; a frame replaced before it
was taken is counted `image_dropped`); one thread decodes at most [camera] rate_hz frames a
second. A frame that does not decode is counted `image_bad_input` and logged; one whose sim
time has no wall time yet (before the clock's first tick) is counted `image_unstamped`.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from zenav.common import codec
from zenav.common import messages as m
from zenav.common.config import Camera
from zenav.services.vps import frames
from zenav.tools import ros2_msgs as rm
from zenav.tools.ros2_node import Node

log = logging.getLogger("zenav.ros2")

IMAGE, INFO = "camera/image_raw", "camera/camera_info"
IMAGE_TYPE, INFO_TYPE = "sensor_msgs/msg/Image", "sensor_msgs/msg/CameraInfo"
FRAME_ID = "camera"
DEPTH = 1  # an image subscriber wants the newest
COUNTERS = ("images", "image_dropped", "image_bad_input", "image_unstamped")

WallTime = Callable[[float], "float | None"]  # a stack time's wall time (None: not known yet)


def camera_info(types: Any, cfg: Camera, t: float) -> Any:
    """sensor_msgs/CameraInfo of the [camera] intrinsics and distortion, stamped `t` [s]."""
    cx, cy = cfg.principal
    return types[INFO_TYPE](
        header=rm.header(types, t, FRAME_ID),
        height=cfg.height,
        width=cfg.width,
        distortion_model="plumb_bob",
        d=np.array([cfg.k1, cfg.k2, cfg.p1, cfg.p2, cfg.k3]),
        k=np.array([cfg.fx, 0.0, cx, 0.0, cfg.fy, cy, 0.0, 0.0, 1.0]),
        r=np.eye(3).reshape(9),
        p=np.array([cfg.fx, 0.0, cx, 0.0, 0.0, cfg.fy, cy, 0.0, 0.0, 0.0, 1.0, 0.0]),
        binning_x=0,
        binning_y=0,
        roi=types["sensor_msgs/msg/RegionOfInterest"](x_offset=0, y_offset=0, height=0, width=0, do_rectify=False),
    )


def image(types: Any, grey: np.ndarray, t: float) -> Any:
    """sensor_msgs/Image `mono8` of a grey image (H x W uint8), stamped `t` [s]."""
    h, w = grey.shape
    return types[IMAGE_TYPE](
        header=rm.header(types, t, FRAME_ID),
        height=h,
        width=w,
        encoding="mono8",
        is_bigendian=0,
        step=w,
        data=np.ascontiguousarray(grey, dtype=np.uint8).reshape(-1),
    )


class CameraImages:
    """Publishes the camera's frames on the node; on_sample from Zenoh's thread, run() on a thread of its own."""

    def __init__(self, node: Node, cfg: Camera, wall_time: WallTime, counts: dict[str, int]) -> None:
        self.cfg, self.wall_time, self.counts = cfg, wall_time, counts
        self.types = node.wire.types()
        self._image = node.publisher(IMAGE, IMAGE_TYPE, depth=DEPTH)
        self._info = node.publisher(INFO, INFO_TYPE, depth=DEPTH)
        self._slot: bytes | None = None
        self._ready = threading.Condition()
        for name in COUNTERS:
            counts.setdefault(name, 0)

    def on_sample(self, key: str, data: bytes) -> None:
        """A frame's bytes (Zenoh's thread): kept in the one slot, the one there before counted dropped."""
        with self._ready:
            if self._slot is not None:
                self.counts["image_dropped"] += 1
            self._slot = data
            self._ready.notify()

    def _take(self, stop: threading.Event) -> bytes | None:
        with self._ready:
            if self._slot is None:
                self._ready.wait(timeout=0.1)
            data, self._slot = self._slot, None
        return None if stop.is_set() else data

    def run(self, stop: threading.Event) -> None:
        """Until `stop`: take the newest frame, at most rate_hz a second, and publish it."""
        period, next_at = 1.0 / self.cfg.rate_hz, 0.0
        while not stop.is_set():
            wait = next_at - time.monotonic()
            if wait > 0.0 and stop.wait(wait):  # the camera's rate: frames that come meanwhile replace each other
                return
            data = self._take(stop)
            if data is None:
                continue
            next_at = time.monotonic() + period
            try:
                self.publish(data)
            except Exception:
                log.exception("could not publish a camera frame")

    def publish(self, data: bytes) -> None:
        """Decode one frame's bytes and publish its Image and CameraInfo (or count why not)."""
        try:
            frame = codec.decode(data, m.CameraFrame)
            grey = frames.decode(frame, self.cfg.width, self.cfg.height)
        except (codec.BadInput, frames.FrameError) as e:
            self.counts["image_bad_input"] += 1
            log.warning("%s: %d bytes dropped: %s", IMAGE, len(data), e)
            return
        t = self.wall_time(frame.t)
        if t is None:
            self.counts["image_unstamped"] += 1
            return
        self._image.put(image(self.types, grey, t))
        self._info.put(camera_info(self.types, self.cfg, t))
        self.counts["images"] += 1
