"""Every message of the wire contract (shared/spec/contract.md), in one place.

Typed, frozen msgspec structs; on the wire each is a plain msgpack map with string
keys. Bounded number types make NaN, inf and absurd values fail validation, so a
bad payload is rejected by decoding alone, with the field named in the error.
Topic messages ignore unknown keys (forward compatible); query requests forbid them
so a typo (`tolerence`) is an error, not a silent default.
"""
from __future__ import annotations

from typing import Annotated, Any, Optional

import msgspec
from msgspec import Meta, Struct

# Bounded scalar types. NaN and inf fail every bound, so these also reject them.
Time = Annotated[float, Meta(ge=0.0, le=1e10)]  # [s] stack clock
Coord = Annotated[float, Meta(ge=-1e4, le=1e4)]  # [m]
Angle = Annotated[float, Meta(ge=-1e3, le=1e3)]  # [rad], wrapped by the receiver
Velocity = Annotated[float, Meta(ge=-1e3, le=1e3)]  # [m/s] or [rad/s]
Accel = Annotated[float, Meta(ge=-1e4, le=1e4)]  # [m/s^2]
Finite = Annotated[float, Meta(ge=-1e12, le=1e12)]  # any finite quantity
Ticks = Annotated[int, Meta(ge=-(2**31), le=2**31 - 1)]  # signed 32-bit counter
Cov9 = Annotated[tuple[Finite, ...], Meta(min_length=9, max_length=9)]  # row-major 3x3
Vec3 = Annotated[tuple[Finite, ...], Meta(min_length=3, max_length=3)]
PosSpeed = Annotated[float, Meta(gt=0.0, le=1e3)]  # a speed limit, > 0
Tolerance = Annotated[float, Meta(gt=0.0, le=1e3)]  # [m] or [rad], > 0
Lease = Annotated[str, Meta(min_length=1, max_length=512)]
ROBOT_ID_PATTERN = r"^[A-Za-z0-9_-]+$"

ZERO_COV: tuple[float, ...] = (0.0,) * 9


class Topic(Struct, frozen=True, kw_only=True):
    """Base of published messages: unknown keys are ignored."""


class Request(Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """Base of query requests: unknown keys are an invalid_argument."""


class Reply(Struct, frozen=True, kw_only=True):
    """Base of query replies."""


# ---------------------------------------------------------------- topics
class Clock(Topic, kw_only=True):
    t: Time  # [s] simulated time
    rtf: Annotated[float, Meta(gt=0.0, le=1e4)] = 1.0  # realtime factor the sim runs at
    wall: Annotated[float, Meta(ge=0.0, le=1e11)] = 0.0  # [s] sender's wall clock (epoch) at t


class Truth(Topic, kw_only=True):
    t: Time
    x: Coord  # [m] map frame
    y: Coord  # [m]
    theta: Angle  # [rad]
    v: Velocity  # [m/s] forward
    omega: Velocity  # [rad/s] CCW


class Encoders(Topic, kw_only=True):
    t: Time
    left: Ticks  # cumulative ticks, wrapping signed 32-bit
    right: Ticks


class Imu(Topic, kw_only=True):
    t: Time
    gyro_z: Velocity  # [rad/s] yaw rate, body frame
    accel_x: Accel  # [m/s^2] forward, body frame
    accel_y: Accel  # [m/s^2] left, body frame


class Compass(Topic, kw_only=True):
    t: Time
    heading: Angle  # [rad] map frame


class VpsPose(Topic, kw_only=True):
    t: Time  # capture time
    x: Coord
    y: Coord
    theta: Angle
    cov: Cov9 = ZERO_COV


class Odom(Topic, kw_only=True):
    t: Time  # encoder sample time
    x: Coord  # [m] odom frame
    y: Coord
    theta: Angle
    v: Velocity
    omega: Velocity
    cov: Cov9 = ZERO_COV
    frame: str = "odom"
    unmeasured_left: Finite = 0.0  # [m] travel the left wheel was commanded this step that its silent encoder did not show
    unmeasured_right: Finite = 0.0  # [m] likewise, right


class Pose(Topic, kw_only=True):
    t: Time  # the odom t this estimate is for
    x: Coord  # [m] map frame
    y: Coord
    theta: Angle
    v: Velocity
    omega: Velocity
    cov: Cov9 = ZERO_COV
    frame: str = "map"
    correction: Vec3 = (0.0, 0.0, 0.0)  # (dx, dy, dtheta) applied by the newest fix
    calibration: dict[str, Finite] = {}  # online estimates of odometry errors


class CmdVel(Topic, kw_only=True):
    t: Time  # pose t acted on; 0 means "now" (clients without the stack clock)
    v: Velocity  # [m/s]
    omega: Velocity  # [rad/s]


class Wheels(Topic, kw_only=True):
    t: Time  # cmd_vel t
    left: Velocity  # [rad/s] wheel angular velocity command after limits
    right: Velocity


class NavState(Topic, kw_only=True):
    t: Time
    state: str  # STOPPED, MOVING_TO_POINT, TURNING_TO_HEADING, MOVING_STRAIGHT, FOLLOWING_PATH
    goal_id: int = 0
    goal: Optional[dict[str, Any]] = None
    result: Optional[str] = None  # succeeded, cancelled, aborted; nil while running
    distance_remaining: Optional[Finite] = None  # [m]
    heading_error: Optional[Finite] = None  # [rad]
    eta: Optional[Finite] = None  # [s]
    elapsed: Finite = 0.0  # [s]
    next_point: Optional[int] = None  # follow_path: index of the point being approached
    cross_track_error: Optional[Finite] = None  # [m]
    message: str = ""


class Fix(Topic, kw_only=True):
    t: Time  # capture time of the fix
    t_arrival: Time
    latency: Finite  # [s] t_arrival - t
    replay_depth: int  # odom samples re-integrated
    innovation: Vec3  # (dx, dy, dtheta) fix minus prediction at capture time
    mahalanobis_d2: Finite
    accepted: bool
    reason: str


class Diag(Topic, kw_only=True):
    t: Time
    service: str
    uptime: Finite  # [s]
    counters: dict[str, int]
    rates: dict[str, Finite]  # topic -> [Hz]
    status: str  # ok, degraded, error
    message: str = ""
    queue: int = 0  # inputs waiting for the worker when this diag was sent


# ---------------------------------------------------------------- queries
class Empty(Request, kw_only=True):
    """A request with no fields (stop, status, localizer/pose)."""


class GoalOptions(Request, kw_only=True):
    speed: Optional[PosSpeed] = None
    tolerance: Optional[Tolerance] = None
    wait: bool = False
    lease: Optional[Lease] = None


class MoveToPoint(GoalOptions, kw_only=True):
    x: Coord
    y: Coord


class TurnToHeading(GoalOptions, kw_only=True):
    heading: Angle


class TurnToPoint(GoalOptions, kw_only=True):
    x: Coord
    y: Coord


class MoveStraight(Request, kw_only=True):
    speed: Annotated[float, Meta(ge=-1e3, le=1e3)]  # [m/s] signed
    distance: Optional[Annotated[float, Meta(gt=0.0, le=1e4)]] = None  # [m]
    wait: bool = False
    lease: Optional[Lease] = None


Point = Annotated[tuple[Coord, ...], Meta(min_length=2, max_length=2)]


class FollowPath(GoalOptions, kw_only=True):
    points: Annotated[list[Point], Meta(min_length=1, max_length=10_000)]


class SetPose(Request, kw_only=True):
    x: Optional[Coord] = None
    y: Optional[Coord] = None
    theta: Optional[Angle] = None


class SimReset(Request, kw_only=True):
    x: Optional[Coord] = None
    y: Optional[Coord] = None
    theta: Optional[Angle] = None
    seed: Optional[Annotated[int, Meta(ge=0, le=2**63 - 1)]] = None


class PoseStamped(Reply, kw_only=True):
    t: float
    x: float
    y: float
    theta: float


class GoalReply(Reply, kw_only=True):
    goal_id: int
    state: str
    speed: Optional[float] = None  # the speed limit used, after clamping
    result: Optional[str] = None
    pose: Optional[PoseStamped] = None
    message: str = ""


class StopReply(Reply, kw_only=True):
    state: str


class StatusReply(Reply, kw_only=True):
    state: str
    is_moving: bool
    goal_id: int
    goal: Optional[dict[str, Any]]
    result: Optional[str]
    distance_remaining: Optional[float]
    pose: Optional[PoseStamped]
    not_ready: str = ""  # why a new goal would be refused now ("": one can start)


class LocalizerPoseReply(Reply, kw_only=True):
    t: float
    x: float
    y: float
    theta: float
    cov: tuple[float, ...]
    calibration: dict[str, float] = {}
    vps_latency: Optional[float] = None  # [s] estimated from the fixes


class ErrorReply(Reply, kw_only=True):
    error: str  # invalid_argument, unavailable, internal
    message: str


def to_builtins(msg: Struct) -> dict[str, Any]:
    """A message as a plain dict (for logs and views)."""
    return msgspec.to_builtins(msg)
