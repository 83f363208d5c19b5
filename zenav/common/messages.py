"""Every message of the wire contract (shared/spec/contract.md), in one place.

Typed, frozen msgspec structs; on the wire each is a plain msgpack map with string
keys. Bounded number types make NaN, inf and absurd values fail validation, so a
bad payload is rejected by decoding alone, with the field named in the error.
Topic messages ignore unknown keys (forward compatible); query requests forbid them
so a typo (`tolerence`) is an error, not a silent default.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal, cast

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
class Clock(Topic, frozen=True, kw_only=True):
    t: Time  # [s] simulated time
    rtf: Annotated[float, Meta(gt=0.0, le=1e4)] = 1.0  # realtime factor the sim runs at
    wall: Annotated[float, Meta(ge=0.0, le=1e11)] = 0.0  # [s] sender's wall clock (epoch) at t
    # the sending sim's instance id (its token zenav/<robot>/instance/sim/<id>); "": a sender without one
    instance: Annotated[str, Meta(max_length=128)] = ""


class Truth(Topic, frozen=True, kw_only=True):
    t: Time
    x: Coord  # [m] map frame
    y: Coord  # [m]
    theta: Angle  # [rad]
    v: Velocity  # [m/s] forward
    omega: Velocity  # [rad/s] CCW
    wall: Annotated[float, Meta(ge=0.0, le=1e11)] = 0.0  # [s] the sim host's wall clock (epoch) at the step; 0: unknown


class Encoders(Topic, frozen=True, kw_only=True):
    t: Time
    left: Ticks  # cumulative ticks, wrapping signed 32-bit
    right: Ticks
    # [rad/s] the wheel speeds commanded while the counts were taken (the sim's command, the board's
    # target): a commanded wheel whose count stays still is a frozen encoder or a stalled wheel.
    # 0: not commanded, or not known (no such check).
    cmd_left: Velocity = 0.0
    cmd_right: Velocity = 0.0


class Imu(Topic, frozen=True, kw_only=True):
    t: Time
    gyro_z: Velocity  # [rad/s] yaw rate, body frame
    accel_x: Accel  # [m/s^2] forward, body frame
    accel_y: Accel  # [m/s^2] left, body frame


class Compass(Topic, frozen=True, kw_only=True):
    t: Time
    heading: Angle  # [rad] map frame


class VpsPose(Topic, frozen=True, kw_only=True):
    t: Time  # capture time
    x: Coord
    y: Coord
    theta: Angle
    cov: Cov9 = ZERO_COV


class CameraFrame(Topic, frozen=True, kw_only=True):
    """One frame of a camera: the overhead one that serves the whole field (zenav/field/camera/frame), or a robot's own
    (camera/onboard/frame)."""

    t: Time  # capture time: the middle of the exposure
    seq: Annotated[int, Meta(ge=0)] = 0  # frame number of the source
    width: Annotated[int, Meta(ge=1, le=8192)]  # [px]
    height: Annotated[int, Meta(ge=1, le=8192)]  # [px]
    encoding: Literal["mono8", "png", "jpeg"] = "mono8"  # mono8: width x height grey bytes, top row first
    exposure: Annotated[float, Meta(ge=0.0, le=1.0)] = 0.0  # [s]
    data: bytes


XY = Annotated[tuple[Coord, ...], Meta(min_length=2, max_length=2)]  # [m] [x, y]
WAY_POINTS = 3  # the most points a robot tells of its way
Way = Annotated[tuple[XY, ...], Meta(max_length=WAY_POINTS)]  # [m] map frame: the next points a robot drives through


class Body(Topic, frozen=True, kw_only=True):
    """Where a simulated robot's body is on the field (zenav/field/sim/body): the other robots' sims keep out of it."""

    t: Time  # the sending sim's time
    robot: Annotated[str, Meta(pattern=ROBOT_ID_PATTERN, max_length=64)]  # whose body
    x: Coord  # [m] map frame: the centre of the disc
    y: Coord  # [m]
    radius: Annotated[float, Meta(gt=0.0, le=10.0)]  # [m] the footprint, a disc
    theta: Angle | None = None  # [rad] `robots`: its heading (None: not sent)
    v: Velocity | None = None  # [m/s] `robots`: its forward speed (None: not sent; taken as standing)
    way: Way = ()  # `robots`: the next points it drives through, from its navigator's command (empty: not told)


class Odom(Topic, frozen=True, kw_only=True):
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


class Pose(Topic, frozen=True, kw_only=True):
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
    slipping: bool = False  # the wheels are found slipping (held by a wall or a robot, pushed): x, y rest on the fixes


class CmdVel(Topic, frozen=True, kw_only=True):
    t: Time  # odom (or pose) t acted on; 0 means "now" (clients without the stack clock)
    v: Velocity  # [m/s]
    omega: Velocity  # [rad/s]
    way: Way = ()  # the next points the command drives toward (the navigator's goal; empty: none told)


class Wheels(Topic, frozen=True, kw_only=True):
    t: Time  # cmd_vel t
    left: Velocity  # [rad/s] wheel angular velocity command after limits
    right: Velocity


class NavState(Topic, frozen=True, kw_only=True):
    t: Time
    state: str  # a contract.State
    goal_id: int = 0
    goal: dict[str, Any] | None = None
    result: str | None = None  # a contract.GoalResult; nil while running
    distance_remaining: Finite | None = None  # [m]
    heading_error: Finite | None = None  # [rad]
    eta: Finite | None = None  # [s]
    elapsed: Finite = 0.0  # [s]
    next_point: int | None = None  # follow_path: index of the point being approached
    cross_track_error: Finite | None = None  # [m]
    message: str = ""
    exit: str | None = None  # why the goal's move ended (within_tolerance, settled, timeout, ...); nil while running
    position_sigma: Finite | None = None  # [m] 1 sigma of the newest pose's position (its worst axis); nil before the first
    heading_sigma: Finite | None = None  # [rad] 1 sigma of its heading
    guard: str = ""  # what the motor's safety layer holds the commands back for now (motor/guard); "": nothing
    traffic: str = ""  # why the goal waits for another robot now (e.g. "waiting for robot r1 to leave the goal"); "": it does not


class FieldMap(Topic, frozen=True, kw_only=True):
    """The field as the navigator knows it (field), sent once a second: its bounds, its obstacles, the robot's footprint."""

    t: Time
    enabled: bool  # false: no bounds
    x_min: Coord  # [m] map frame
    x_max: Coord
    y_min: Coord
    y_max: Coord
    obstacles: list[dict[str, Any]]  # each {"name": str, "polygon": [[x, y], ...]} or {"name": str, "circle": [x, y, r]} [m]
    radius: Finite  # [m] the robot's footprint ([robot] radius)
    margin: Finite  # [m] kept clear beyond it ([field] margin)


class GuardState(Topic, frozen=True, kw_only=True):
    """What the motor's safety layer limits (motor/guard), sent when it changes."""

    t: Time
    reason: str  # what it holds the command back for, and how far it is ("": nothing, the command passes)
    v: Velocity  # [m/s] the forward speed it allows now
    stopped: bool = False  # the forward speed is cut to zero


class Plan(Topic, frozen=True, kw_only=True):
    """The points a goal drives through (nav/plan), published when it starts: the user's, with the planner's detours."""

    t: Time
    goal_id: int
    points: list[Point]  # [m] map frame, [x, y], in order; the last is the goal's
    length: Finite  # [m] from the start through every point
    planned: bool  # some leg was planned around an obstacle
    clearance: Finite | None = None  # [m] the least distance of the way from an obstacle; nil without obstacles


class Fix(Topic, frozen=True, kw_only=True):
    t: Time  # capture time of the fix
    t_arrival: Time
    latency: Finite  # [s] t_arrival - t
    replay_depth: int  # odom samples re-integrated
    innovation: Vec3  # (dx, dy, dtheta) fix minus prediction at capture time
    mahalanobis_d2: Finite
    accepted: bool
    reason: str
    latency_estimate: Finite | None = None  # [s] VPS latency estimated online ([localizer] latency = "estimate"), else None
    latency_sigma: Finite | None = None  # [s] 1 sigma of latency_estimate


class Diag(Topic, frozen=True, kw_only=True):
    t: Time
    service: str
    uptime: Finite  # [s]
    counters: dict[str, int]
    rates: dict[str, Finite]  # topic -> [Hz]
    status: str  # ok, degraded, error
    message: str = ""
    queue: int = 0  # inputs waiting for the worker when this diag was sent
    cpu: Finite | None = None  # [cores] the service's process's CPU time per wall second since the previous diag
    # [us] per input topic, the mean wall time serving one of its messages since the previous diag (decoding
    # it, the handler, publishing what it returned), in the service's own process as deployed (composed: publishing
    # includes the work of the services in the process that take the output at once)
    serve: dict[str, Finite] = {}


# ---------------------------------------------------------------- queries
class Empty(Request, frozen=True, kw_only=True):
    """A request with no fields (stop, status, localizer/pose)."""


class GoalOptions(Request, frozen=True, kw_only=True):
    speed: PosSpeed | None = None
    tolerance: Tolerance | None = None
    wait: bool = False
    lease: Lease | None = None
    timeout: Annotated[float, Meta(gt=0.0, le=1e4)] | None = None  # [s] the move stops after this long (exit timeout)
    min_speed: Annotated[float, Meta(ge=0.0, le=1e3)] | None = None  # [m/s] (turns [rad/s]) > 0: chained, no slower than this
    early_exit_range: Annotated[float, Meta(ge=0.0, le=1e3)] | None = None  # [m] (turns [rad]) a chained move ends this far before


class MoveToPoint(GoalOptions, frozen=True, kw_only=True):
    x: Coord
    y: Coord
    forwards: bool = True  # False: drive there backwards (LemLib's forwards)
    plan: bool = True  # around the [field] obstacles where the straight way is blocked; False: straight, as asked


class MoveToPose(GoalOptions, frozen=True, kw_only=True):
    x: Coord
    y: Coord
    theta: Angle  # [rad] heading to arrive with
    heading_tolerance: Tolerance | None = None  # [rad]
    lead: Annotated[float, Meta(ge=0.0, le=1.0)] | None = None  # [-] boomerang carrot distance per metre to the goal
    forwards: bool = True  # False: back in (theta is still the heading of the robot's front)
    plan: bool = True  # around the [field] obstacles where the straight way is blocked; False: straight, as asked


TurnDirection = Literal["auto", "cw", "ccw"]  # the shorter way, clockwise, counter-clockwise (LemLib's AngularDirection)


class TurnToHeading(GoalOptions, frozen=True, kw_only=True):
    heading: Angle
    direction: TurnDirection = "auto"  # cw / ccw: that way round, the long way if need be


class SwingToHeading(GoalOptions, frozen=True, kw_only=True):
    heading: Angle
    side: Literal["left", "right"]  # the wheel that stays still: the robot turns about it (LemLib's lockedSide)
    direction: TurnDirection = "auto"  # cw / ccw: that way round, the long way if need be


class TurnToPoint(GoalOptions, frozen=True, kw_only=True):
    x: Coord
    y: Coord
    forwards: bool = True  # False: face the point with the robot's back
    direction: TurnDirection = "auto"  # cw / ccw: that way round, the long way if need be


class MoveStraight(Request, frozen=True, kw_only=True):
    speed: Annotated[float, Meta(ge=-1e3, le=1e3)]  # [m/s] signed
    distance: Annotated[float, Meta(gt=0.0, le=10000.0)] | None = None  # [m]
    wait: bool = False
    lease: Lease | None = None


Point = Annotated[tuple[Coord, ...], Meta(min_length=2, max_length=3)]  # [x, y] or [x, y, tolerance [m]]


class FollowPath(GoalOptions, frozen=True, kw_only=True):
    points: Annotated[list[Point], Meta(min_length=1, max_length=10_000)]
    waypoint_tolerance: Tolerance | None = None  # [m] of the points before the last that name none
    forwards: bool = True  # False: drive the path backwards
    plan: bool = True  # detours around the [field] obstacles between the points; False: straight between them


class SetPose(Request, frozen=True, kw_only=True):
    """Any subset of x, y, theta but none (SET_POSE_EMPTY): the one left out keeps its value (setPosition, setHeading)."""

    x: Coord | None = None
    y: Coord | None = None
    theta: Angle | None = None


# The invalid_argument of a set_pose without x, y or theta (the localizer's, and the library's before sending):
# it would set nothing, and only reset the estimate's history.
SET_POSE_EMPTY = "x, y, theta: none given; set_pose takes at least one (one left out keeps its value)"


class SimReset(Request, frozen=True, kw_only=True):
    x: Coord | None = None
    y: Coord | None = None
    theta: Angle | None = None
    seed: Annotated[int, Meta(ge=0, le=2**63 - 1)] | None = None


class PoseStamped(Reply, frozen=True, kw_only=True):
    t: float
    x: float
    y: float
    theta: float


class GoalReply(Reply, frozen=True, kw_only=True):
    goal_id: int
    state: str
    speed: float | None = None  # the speed limit used, after clamping
    result: str | None = None
    pose: PoseStamped | None = None
    message: str = ""
    exit: str | None = None  # why the move ended (within_tolerance, settled, timeout, ...); nil until it ends


class StopReply(Reply, frozen=True, kw_only=True):
    state: str


class StatusReply(Reply, frozen=True, kw_only=True):
    state: str
    is_moving: bool
    goal_id: int
    goal: dict[str, Any] | None
    result: str | None
    distance_remaining: float | None
    pose: PoseStamped | None
    not_ready: str = ""  # why a new goal would be refused now ("": one can start)
    exit: str | None = None  # why the newest goal's move ended; nil while it runs
    position_sigma: float | None = None  # [m] as in NavState
    heading_sigma: float | None = None  # [rad] as in NavState
    plan: list[Point] | None = None  # [m] the newest goal's points as driven (detours included); nil for a turn or a straight


class ClockReply(Reply, frozen=True, kw_only=True):
    """The stack's clock, for a camera host measuring its own against it (time/sync)."""

    t: float  # [s] stack clock when the query was served


class LocalizerPoseReply(Reply, frozen=True, kw_only=True):
    t: float
    x: float
    y: float
    theta: float
    cov: tuple[float, ...]
    calibration: dict[str, float] = {}
    vps_latency: float | None = None  # [s] estimated from the fixes


class ErrorReply(Reply, frozen=True, kw_only=True):
    error: str  # a contract.ErrorCode
    message: str  # for people: its words may change; programs decide on `error` and `reason`
    reason: str = ""  # a contract.Reason: which refusal it is ("": none given)


def to_builtins(msg: Struct) -> dict[str, Any]:
    """A message as a plain dict (for logs and views)."""
    return cast(dict[str, Any], msgspec.to_builtins(msg))
