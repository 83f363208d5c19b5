"""The navigator's tunables: the `[navigator]` config section (documented in zenav/data/default.toml)."""

from __future__ import annotations

from typing import Annotated, Literal, get_args

from msgspec import Meta, Struct

Pos = Annotated[float, Meta(gt=0.0, le=1e3)]
NonNeg = Annotated[float, Meta(ge=0.0, le=1e3)]
Gain = Annotated[float, Meta(ge=-1e3, le=1e3)]
Limit = Annotated[float, Meta(gt=0.0)]  # inf turns the check off
Speed = Annotated[float, Meta(ge=1e-3, le=1e3)]  # [m/s] or [rad/s] a goal's speed: at least goalschema.SLOWEST

ControllerName = Literal["pid", "polar", "proportional"]
CONTROLLERS: tuple[str, ...] = get_args(ControllerName)
PoseControllerName = Literal["polar", "boomerang"]
POSE_CONTROLLERS: tuple[str, ...] = get_args(PoseControllerName)
ControlOn = Literal["odom", "pose"]  # roles.CONTROL_ON


class Params(Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """Speeds, tolerances, checks and controller gains of the navigator."""

    control_on: ControlOn = "odom"  # the control loop runs on each odom sample (the localizer's correction applied) or each pose
    controller: ControllerName = "pid"  # point tracker: pid (rotation PID), polar (rho/alpha/beta), proportional
    pose_controller: PoseControllerName = "boomerang"  # move_to_pose: boomerang (LemLib carrot) or polar (rho/alpha/beta)
    lead: Annotated[float, Meta(ge=0.0, le=1.0)] = 0.6  # [-] boomerang: carrot distance behind the goal per metre to it
    speed: Speed = 0.2  # [m/s] forward speed of a goal that names none
    max_speed: Speed = 0.3  # [m/s] forward speed limit; faster requests are clamped
    crawl_speed: NonNeg = 0.03  # [m/s] slowest forward command while driving (above the motor deadband; not a goal's min_speed)
    decel: Pos = 0.5  # [m/s^2] braking into a goal point or the end of a straight
    turn_speed: Speed = 2.0  # [rad/s] turn rate of a turn that names none
    max_turn_speed: Speed = 3.0  # [rad/s] turn rate limit; faster requests are clamped
    min_turn_speed: NonNeg = 0.4  # [rad/s] slowest turn command while turning (above the motor deadband)
    turn_decel: Pos = 4.0  # [rad/s^2] braking into a target heading
    tolerance: Pos = 0.01  # [m] goal position tolerance of a goal that names none
    heading_tolerance: Pos = 0.0175  # [rad] heading tolerance of a turn or pose that names none (1 deg: above the fused heading noise)
    waypoint_tolerance: Pos = 0.05  # [m] follow_path: tolerance of an intermediate point that names none
    avoid_robots: bool = True  # drive round the other robots on the field (`robots`), keeping right, and give way by id
    robot_wait: Pos = 20.0  # [s] a goal that waited for other robots this long in all aborts (stalled)
    corner_tolerance: Pos = 0.01  # [m] a planned detour's corners are passed within this ([field] margin must hold it)
    through_speed: NonNeg = 0.08  # [m/s] follow_path: slowest speed through an intermediate point (0: may stop)
    lock_distance: NonNeg = 0.08  # [m] this close to the final point the robot stops turning toward it
    stop_lead: NonNeg = 0.06  # [s] a stop is predicted to coast this long at the current rate (motor lag)
    rest_time: NonNeg = 0.2  # [s] after a move stops, zero is held this long, then the error is re-checked
    slip_wait: NonNeg = 1.5  # [s] and at most this much longer while the localizer finds the wheels slipping
    chain_time: NonNeg = 0.2  # [s] after a chained move ends (exit chained) its last command is held this long for the next goal
    # moves again this many times at most while the re-check is over the tolerance (not a move held where it stopped)
    retries: Annotated[int, Meta(ge=0, le=10)] = 2
    settle_error: Pos = 0.02  # [m] a position error held under this for settle_time ends the move (settled)
    settle_heading_error: Pos = 0.035  # [rad] likewise for a heading error (2 deg)
    settle_time: Pos = 0.5  # [s]
    big_error: Pos = 0.05  # [m] a position error held under this for big_time ends the move (big_error)
    big_heading_error: Pos = 0.09  # [rad] likewise for a heading error (5 deg)
    big_time: Pos = 1.5  # [s]
    goal_timeout: NonNeg = 0.0  # [s] a goal that names no timeout stops after this long (timeout); 0: never
    progress_timeout: Pos = 5.0  # [s] a goal without progress for this long aborts (stalled)
    progress_distance: Pos = 0.01  # [m] the least gain toward a position goal that counts as progress
    progress_angle: Pos = 0.02  # [rad] the least gain toward a heading that counts as progress
    stale_after: Pos = 0.5  # [s] a goal aborts when the newest pose is older than this
    max_position_sigma: Limit = 0.5  # [m] a goal aborts (or is refused) while the pose's position sigma is larger (once a vps is seen)
    max_heading_sigma: Limit = 0.35  # [rad] likewise for the heading sigma (20 deg)
    lease_grace: Pos = 0.5  # [s] how long a goal's lease token may take to be seen alive
    check_period: Pos = 0.05  # [s] period of the stale pose, progress and lease checks
    state_period: Pos = 0.2  # [s] period of nav/state between changes (5 Hz)
    pid_kp: Gain = 4.0  # [1/s] PID: heading error -> turn rate
    pid_ki: Gain = 0.5  # [1/s^2] PID: integral of the heading error -> turn rate
    pid_kd: Gain = 0.1  # [-] PID: turn rate taken off per unit of measured turn rate (damping)
    pid_i_limit: NonNeg = 0.2  # [rad * s] PID: anti-windup bound on the integral
    pid_speed_gain: Pos = 2.0  # [1/s] PID: forward speed per metre to the goal
    pid_heading_limit: Pos = 1.0  # [rad] PID: forward speed falls linearly to zero at this heading error
    k_rho: Gain = 3.0  # [1/s] polar: forward speed per metre to the goal (> 0)
    k_alpha: Gain = 8.0  # [1/s] polar: turn rate per radian of bearing error
    k_beta: Gain = -3.0  # [1/s] polar: turn rate per radian of approach-heading error (< 0)
    prop_speed_gain: Pos = 2.0  # [1/s] proportional: forward speed per metre to the goal
    prop_heading_gain: Pos = 4.0  # [1/s] proportional: turn rate per radian of bearing error
    straight_heading_gain: Pos = 4.0  # [1/s] move_straight: turn rate per radian off the line heading
    straight_track_gain: Pos = 10.0  # [1/m] move_straight: heading correction per metre of cross-track error
    straight_max_time: Pos = 30.0  # [s] move_straight without a distance ends (aborted) after this long
    max_path_points: Annotated[int, Meta(ge=1, le=10_000)] = 10_000  # [points] longer follow_path requests are refused
