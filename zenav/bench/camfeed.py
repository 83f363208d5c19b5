"""The robot's own camera for the board bench: frames of the field's tags at 10 Hz, 640 x 480.

A real robot's camera is read by `zenav camera stream --onboard`, which publishes each frame raw (mono8, its JPEG
decoded) on zenav/<robot>/camera/onboard/frame. Here a thread of the bench's process does the same with the sim's
onboard camera (world/onboard.py, [onboard_camera] defaults with their realistic errors: lens, mount, tags as placed,
motion blur, shake, JPEG, frames lost): each frame is rendered at the pose the emulated board's wheels drove to (they
do not slip: the truth, integrated here from their counts at SAMPLE_HZ, from where the stack's pose was set), stamped
with the time of its counts, so the vps detects the tags, solves the pose and its fixes reach the localizer. Its CPU
is the bench's, not the robot computer's, and it listens to no topic of the robot's (which would cost the robot's
processes the sending).
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from types import TracebackType

from zenav.common import messages as m
from zenav.common.client import Client
from zenav.common.config import RobotConfig, Settings
from zenav.services.sim.onboard import OnboardFrames
from zenav.services.vps import frames
from zenav.world.onboard import moved

RATE = 10.0  # [Hz] frames sent
SAMPLE_HZ = 200.0  # [Hz] the wheels' counts are integrated at
TOPIC = "camera/onboard/frame"


class CameraFeed:
    """Publishes the onboard camera's frames of the robot where its wheels took it, from a thread, while in a with block."""

    def __init__(self, client: Client, counts: Callable[[], tuple[int, int]], ticks_per_rev: int, rate: float = RATE) -> None:
        self.client, self.counts, self.period = client, counts, 1.0 / rate
        robot = Settings.load(None).section("robot", RobotConfig)
        self.per_tick = 2.0 * math.pi * robot.wheel_radius / ticks_per_rev  # [m] a wheel's travel per tick
        self.track = robot.track_width
        self.frames = OnboardFrames(Settings.load(None, onboard_camera={"rate_hz": rate}))
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="camera-feed", daemon=True)

    def __enter__(self) -> CameraFeed:
        self._thread.start()
        return self

    def __exit__(self, typ: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None) -> None:
        self._stop.set()
        self._thread.join()

    def _run(self) -> None:
        """Integrate the wheels' travel, and film every period."""
        pose, last, t = (0.0, 0.0, 0.0), self.counts(), time.monotonic()
        due = t
        while not self._stop.wait(1.0 / SAMPLE_HZ):
            now, counts = time.monotonic(), self.counts()
            dt = max(now - t, 1e-6)
            left, right = ((c - c0) * self.per_tick for c, c0 in zip(counts, last))
            v, omega = (left + right) / (2.0 * dt), (right - left) / (self.track * dt)
            pose, last, t = moved(*pose, v, omega, dt), counts, now
            if now >= due:
                due += self.period
                self._film(pose, v, omega)

    def _film(self, pose: tuple[float, float, float], v: float, omega: float) -> None:
        """Render the frame of the robot at `pose` moving at (v [m/s], omega [rad/s]), now, and send it raw."""
        truth = m.Truth(t=time.time(), x=pose[0], y=pose[1], theta=pose[2], v=v, omega=omega)
        shot = self.frames.frame(truth)
        if shot is None:
            return  # lost on the way, as [onboard_camera] drop_rate loses them
        img = frames.decode(shot, shot.width, shot.height)  # as `zenav camera stream` sends it: raw
        self.client.publish(TOPIC, frames.encode(img, shot.t, shot.seq, shot.exposure))
