"""The sim's overhead camera: frames of the truth at the camera's rate, rendered beside the physics.

Rendering takes several milliseconds, longer than a physics step may wait: each frame is
drawn and sent by a worker thread, at a lower priority (runtime.background_thread), while
the steps go on. A frame that falls due while the previous one is still being drawn is
skipped (counted by the caller).
"""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor, wait
from typing import Any, Protocol

import numpy as np

from zenav.common import messages as m
from zenav.common.config import Camera
from zenav.common.runtime import background_thread
from zenav.world.camera_errors import dropped, imperfect, jpeg, shake
from zenav.world.render import Body, Renderer

RNG_STREAM = 0x534841  # "SHA": the mount's shake and the frames lost


class Cadence:
    """Frame times at `rate_hz` on the sim's step grid."""

    def __init__(self, rate_hz: float) -> None:
        self.period = 1.0 / rate_hz  # [s]
        self._next: float | None = None  # [s] time of the next frame

    def due(self, t: float) -> bool:
        """Whether a frame is taken at sim time t [s] (and then the next one is scheduled)."""
        if self._next is None or not self._next - self.period <= t < self._next + self.period:
            self._next = t  # first sample, a gap, or time went backwards (the sim restarted)
        if t < self._next - 1e-6:
            return False
        self._next += self.period
        return True


class Frames(Protocol):
    """A simulated camera: whether a frame is due at a time, and the frame of a truth sample (None: lost)."""

    lost: int  # frames lost on the way

    def due(self, t: float) -> bool: ...

    def frame(self, truth: m.Truth) -> m.CameraFrame | None: ...


class FieldCamera:
    """Frames of the robot with tag `tag` (None: no tag, the floor only) at `rate_hz`, on the sim's step grid;
    `hidden(t)`: the robot is out of sight at t (the scenario's VPS outage: someone between camera and robot).
    The camera has a real one's errors ([camera] model, world/camera_errors.py): frames are rendered through the
    true lens and mount, shaken, some lost, sent as JPEG, and stamped on the camera host's clock."""

    def __init__(self, cfg: Camera, seed: int, tag: int | None, hidden: Callable[[float], bool] = lambda t: False) -> None:
        self.cfg, self.tag, self.hidden = cfg, tag, hidden
        self.errors = imperfect(cfg, seed)
        self.renderer = Renderer(self.errors.true, seed, readout=self.errors.readout)
        self.rng = np.random.default_rng([seed, RNG_STREAM])
        self.due = Cadence(cfg.rate_hz).due
        self.seq = 0
        self.lost = 0  # frames lost on the way (drop_rate)

    def frame(self, truth: m.Truth) -> m.CameraFrame | None:
        """The frame whose exposure is centred on truth.t, stamped on the camera host's clock; None: lost on the way."""
        bodies = []
        if self.tag is not None and not self.hidden(truth.t):
            bodies.append(Body(self.tag, truth.x, truth.y, truth.theta, truth.v, truth.omega))
        img = shake(self.renderer.render(truth.t, bodies), self.errors, self.rng)
        self.seq += 1
        if dropped(self.errors, self.rng):
            self.lost += 1
            return None
        h, w = img.shape
        t, q = self.errors.host_time(truth.t), self.errors.jpeg_quality
        if q > 0:
            return m.CameraFrame(t=t, seq=self.seq, width=w, height=h, encoding="jpeg", exposure=self.cfg.exposure, data=jpeg(img, q))
        return m.CameraFrame(t=t, seq=self.seq, width=w, height=h, exposure=self.cfg.exposure, data=img.tobytes())


class Shutter:
    """Draws and sends frames on one worker thread, skipping a frame while the last is unfinished."""

    def __init__(self, camera: Frames, send: Callable[[m.CameraFrame], None]) -> None:
        self.camera, self.send = camera, send
        # Drawing at a lower priority than the physics and the control loop's services (a real camera draws its
        # frames on its own hardware): on a shared computer they get the cores first.
        self._worker = ThreadPoolExecutor(max_workers=1, thread_name_prefix="zenav-sim-camera", initializer=background_thread)
        self._last: Future[Any] | None = None
        self.error = ""  # why the last frame failed ("" once one is sent)
        self.failed = 0  # frames that failed

    def take(self, truth: m.Truth) -> str | None:
        """Start a frame of this truth sample if one is due: "taken", "skipped" (the last still drawing) or None."""
        if not self.camera.due(truth.t):
            return None
        if self._last is not None and not self._last.done():
            return "skipped"
        self._last = self._worker.submit(self._shoot, truth)
        return "taken"

    def _shoot(self, truth: m.Truth) -> None:
        try:
            frame = self.camera.frame(truth)
            if frame is not None:
                self.send(frame)
            self.error = ""
        except Exception as e:  # reported by the caller through `error` and `failed`: the worker must go on
            self.error = f"{type(e).__name__}: {e}"
            self.failed += 1

    def idle(self, timeout: float) -> bool:
        """Wait up to timeout [s] for the frame being drawn; whether none is left."""
        if self._last is not None:
            wait([self._last], timeout)
        return self._last is None or self._last.done()

    def close(self) -> None:
        """Finish the frame being drawn, then stop the worker."""
        self._worker.shutdown(wait=True)
