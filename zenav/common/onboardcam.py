"""The [onboard_camera] section: a camera on the robot that reads the field's fixed tags ([field] tags).

Its pose on the robot is WPILib's robot-to-camera transform: x forward, y left, z up from the middle of the wheels'
axle on the floor, then yaw about z, pitch about y (> 0 tilts it down), roll about x. With all three 0 it looks
straight ahead, level, image x to the robot's right. Intrinsics and distortion follow OpenCV's model.
"""

from __future__ import annotations

import math
from typing import Annotated, Literal

from msgspec import Meta, Struct

MAX_FOV = math.radians(170.0)  # [rad] widest field of view across the frame a pinhole model describes

Size = Annotated[float, Meta(gt=0.0, le=1e4)]


class OnboardCamera(Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """A camera on the robot: where it is on the robot, its lens, and what the sim makes of it."""

    width: Annotated[int, Meta(ge=16, le=8192)] = 640  # [px]
    height: Annotated[int, Meta(ge=16, le=8192)] = 480  # [px]
    rate_hz: Annotated[float, Meta(gt=0.0, le=1000.0)] = 15.0  # [Hz] frames captured
    x: Annotated[float, Meta(ge=-10.0, le=10.0)] = 0.05  # [m] optical centre ahead of the middle of the wheels' axle
    y: Annotated[float, Meta(ge=-10.0, le=10.0)] = 0.0  # [m] left of it
    z: Annotated[float, Meta(ge=0.0, le=10.0)] = 0.2  # [m] above the floor
    yaw: Annotated[float, Meta(ge=-7.0, le=7.0)] = 0.0  # [rad] optical axis from the robot's forward, left positive
    pitch: Annotated[float, Meta(ge=-1.6, le=1.6)] = 0.0  # [rad] > 0 tilts it down
    roll: Annotated[float, Meta(ge=-3.2, le=3.2)] = 0.0  # [rad] about the optical axis
    fx: Size = 500.0  # [px] focal length
    fy: Size = 500.0  # [px]
    cx: Annotated[float, Meta(ge=0.0, le=8192.0)] | None = None  # [px] principal point; None: the image centre
    cy: Annotated[float, Meta(ge=0.0, le=8192.0)] | None = None  # [px]
    k1: Annotated[float, Meta(ge=-10.0, le=10.0)] = 0.0  # radial distortion (OpenCV model)
    k2: Annotated[float, Meta(ge=-10.0, le=10.0)] = 0.0
    p1: Annotated[float, Meta(ge=-1.0, le=1.0)] = 0.0  # tangential distortion
    p2: Annotated[float, Meta(ge=-1.0, le=1.0)] = 0.0
    k3: Annotated[float, Meta(ge=-10.0, le=10.0)] = 0.0
    noise: Annotated[float, Meta(ge=0.0, le=100.0)] = 2.0  # [grey levels] sim: sensor noise, 1 sigma
    link_delay: Annotated[float, Meta(ge=0.0, le=10.0)] = 0.05  # [s] added after detection (the coprocessor's link)
    corner_sigma: Annotated[float, Meta(gt=0.0, le=100.0)] = 0.3  # [px] 1 sigma of a tag corner, the base of a fix's covariance
    max_distance: Annotated[float, Meta(gt=0.0, le=100.0)] = 3.0  # [m] a tag farther than this gives no one-tag fix
    max_ambiguity: Annotated[float, Meta(gt=0.0, le=1.0)] = 0.2  # a one-tag fix whose two poses fit this alike is refused
    # The camera's own errors (world/camera_errors.py), at a real camera's size: the sim renders them; the vps stamps
    # the fix at its tags' rows by the readout and widens its covariance by the rest. "ideal": none of them.
    model: Literal["realistic", "ideal"] = "realistic"
    calibration_error: Annotated[float, Meta(ge=0.0, le=10.0)] = 0.3  # [px] rms: the true lens off the calibrated one
    mount_tilt: Annotated[float, Meta(ge=0.0, le=0.2)] = 0.0035  # [rad] sim: the mount off its configured pitch and yaw
    vibration: Annotated[float, Meta(ge=0.0, le=0.05)] = 0.0005  # [rad] 1 sigma: the chassis' shake, frame to frame
    tag_position_error: Annotated[float, Meta(ge=0.0, le=0.5)] = 0.003  # [m] 1 sigma: a field tag's true place off its layout
    print_scale_error: Annotated[float, Meta(ge=0.0, le=0.2)] = 0.005  # [-] 1 sigma: the printed tags' scale off 1
    exposure: Annotated[float, Meta(ge=0.0, le=1.0)] = 0.008  # [s] sim: the robot's own motion blurs over this time
    readout: Annotated[float, Meta(ge=0.0, le=1.0)] = 0.03  # [s] rolling shutter: top row to bottom row; 0: global shutter
    jpeg_quality: Annotated[int, Meta(ge=0, le=100)] = 80  # sim: frames sent as JPEG of this quality; 0: raw mono8
    drop_rate: Annotated[float, Meta(ge=0.0, le=0.9)] = 0.02  # sim: fraction of frames lost on the way

    def __post_init__(self) -> None:
        for name, c, size in (("cx", self.cx, self.width), ("cy", self.cy, self.height)):
            if c is not None and not 0.0 < c < size:
                raise ValueError(f"{name} = {c:g} px lies outside the {self.width} x {self.height} frame")
        for name, f, size in (("fx", self.fx, self.width), ("fy", self.fy, self.height)):
            if 2.0 * math.atan(size / (2.0 * f)) > MAX_FOV:
                raise ValueError(f"{name} = {f:g} px on a {size} px side is a field of view over 170 deg: not a pinhole lens")

    @property
    def principal(self) -> tuple[float, float]:
        """(cx, cy) [px]."""
        return (self.width / 2.0 if self.cx is None else self.cx, self.height / 2.0 if self.cy is None else self.cy)
