"""The robot's own camera for the board bench: frames of the field's tags at 10 Hz, 640 x 480.

A real robot's camera is read by `zenav camera stream --onboard`, which publishes each frame raw (mono8, its JPEG
decoded) on zenav/<robot>/camera/onboard/frame. Here a thread of the bench's process does the same with the sim's
onboard camera (world/onboard.py, [onboard_camera] defaults with their realistic errors: lens, mount, tags as placed,
motion blur, shake, JPEG, frames lost): each frame is rendered at the odometry's newest pose (the emulated board's
wheels are the truth: they do not slip), stamped with its encoder sample's time, so the vps detects the tags, solves
the pose and its fixes reach the localizer. Its CPU is the bench's, not the robot computer's.
"""

from __future__ import annotations

import threading
import time
from types import TracebackType

from zenav.common import messages as m
from zenav.common.client import Client
from zenav.common.config import Settings
from zenav.services.sim.onboard import OnboardFrames
from zenav.services.vps import frames

RATE = 10.0  # [Hz] frames sent
TOPIC = "camera/onboard/frame"


class CameraFeed:
    """Publishes the onboard camera's frames of the robot at the odometry's pose, from a thread, while in a with block."""

    def __init__(self, client: Client, rate: float = RATE) -> None:
        self.client, self.period = client, 1.0 / rate
        self.frames = OnboardFrames(Settings.load(None, onboard_camera={"rate_hz": rate}))
        self.odom = client.latest("odom")
        self.sent = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="camera-feed", daemon=True)

    def __enter__(self) -> CameraFeed:
        self._thread.start()
        return self

    def __exit__(self, typ: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None) -> None:
        self._stop.set()
        self._thread.join()

    def _run(self) -> None:
        due = time.monotonic()
        while not self._stop.wait(max(due - time.monotonic(), 0.0)):
            due += self.period
            odom: m.Odom | None = self.odom.msg
            if odom is None:
                continue
            truth = m.Truth(t=odom.t, x=odom.x, y=odom.y, theta=odom.theta, v=odom.v, omega=odom.omega)
            shot = self.frames.frame(truth)
            if shot is None:
                continue  # lost on the way, as [onboard_camera] drop_rate loses them
            img = frames.decode(shot, shot.width, shot.height)  # as `zenav camera stream` sends it: raw
            self.client.publish(TOPIC, frames.encode(img, shot.t, shot.seq, shot.exposure))
            self.sent += 1
