"""The robot's true body: geometry from the scenario, motors (lag, deadband, saturation), slip, exact arcs.

The wheel radii vary under load (rubber tyres compress): with the payload
the scenario schedules, and with the load transfer of the previous step's forward
(both wheels) and centripetal (the outer wheel more, the inner less) acceleration,
around the mean the scenario's radius errors give.

Pure: time comes in as `dt`, randomness from the generator passed in.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from zenav.common.config import RobotConfig
from zenav.common.geometry import wrap_angle
from zenav.common.scenarios import Scenario


class Load(NamedTuple):
    """How the tyres compress under load: relative radius changes (0: none)."""

    schedule: tuple[tuple[float, float], ...] = ()  # (from t [s], payload [kg] above the nominal), in time order
    per_kg: float = 0.0  # [1/kg] relative radius change per kg of payload
    per_accel: float = 0.0  # [s^2/m] relative radius change of both wheels per m/s^2 of forward acceleration
    per_lateral: float = 0.0  # [s^2/m] of the outer wheel per m/s^2 of centripetal acceleration (inner: opposite)


NO_LOAD = Load()


def payload(schedule: tuple[tuple[float, float], ...], t: float) -> float:
    """[kg] the payload above the nominal at time t [s]: the newest step started by then (0 before the first)."""
    kg = 0.0
    for start, mass in schedule:
        if start > t:
            break
        kg = mass
    return kg


class World(NamedTuple):
    """The true robot: what the world is, not what the stack believes."""

    radius_left: float  # [m] true wheel radius
    radius_right: float  # [m]
    track: float  # [m] true track width, wheel contact to contact
    motor_lag: float  # [s] first-order time constant of each motor
    deadband: float  # [rad/s] commands smaller than this do not turn the wheel
    motor_max: float  # [rad/s] saturation
    slip_sigma: float  # relative noise on each wheel's travel per step, 1 sigma
    load: Load = NO_LOAD  # radius changes under load, on top of radius_left / radius_right


def world(robot: RobotConfig, scen: Scenario) -> World:
    """The true robot of a scenario around the nominal geometry."""
    r = robot.wheel_radius
    return World(
        radius_left=r * (1.0 + scen.wheel_radius_err_left + scen.load_radius_err),
        radius_right=r * (1.0 + scen.wheel_radius_err_right + scen.load_radius_err),
        track=robot.track_width * (1.0 + scen.track_width_err),
        motor_lag=scen.motor_lag,
        deadband=scen.motor_deadband,
        motor_max=scen.motor_max,
        slip_sigma=scen.slip_sigma,
        load=Load(scen.load_payload, scen.load_radius_per_kg, scen.load_radius_per_accel, scen.load_radius_per_lateral),
    )


class State(NamedTuple):
    """The simulated robot at one instant."""

    x: float = 0.0  # [m] map frame
    y: float = 0.0  # [m]
    theta: float = 0.0  # [rad] wrapped to (-pi, pi]
    speed_left: float = 0.0  # [rad/s] wheel angular velocity
    speed_right: float = 0.0  # [rad/s]
    angle_left: float = 0.0  # [rad] cumulative wheel angle: what the encoder sees
    angle_right: float = 0.0  # [rad]
    v: float = 0.0  # [m/s] forward, mean over the last step
    omega: float = 0.0  # [rad/s] CCW, mean over the last step
    accel: float = 0.0  # [m/s^2] forward acceleration over the last step: the motors', or the body's where held (sim.py)
    t: float = 0.0  # [s] time since the start (the payload schedule's clock)


def motor_target(cmd: float, w: World) -> float:
    """The speed a motor settles at for a command [rad/s]: deadband, then saturation."""
    if abs(cmd) < w.deadband:
        return 0.0
    return max(-w.motor_max, min(w.motor_max, cmd))


def motor_step(speed: float, target: float, lag: float, dt: float) -> tuple[float, float]:
    """First-order motor over dt, solved exactly: (speed at the end [rad/s], angle turned [rad])."""
    if lag <= 0.0:
        return target, target * dt
    decay = math.exp(-dt / lag)
    return target + (speed - target) * decay, target * dt + (speed - target) * lag * (1.0 - decay)


def arc(x: float, y: float, theta: float, ds: float, dtheta: float) -> tuple[float, float, float]:
    """The pose after travelling ds [m] along a circular arc turning by dtheta [rad] (exact)."""
    h = dtheta / 2.0
    # Chord of the arc: ds * sin(h) / h, with the series where h is tiny.
    chord = ds * (math.sin(h) / h if abs(h) > 1e-6 else 1.0 - h * h / 6.0)
    mid = theta + h
    return x + chord * math.cos(mid), y + chord * math.sin(mid), wrap_angle(theta + dtheta)


def radii(s: State, w: World) -> tuple[float, float]:
    """[m] (left, right) true wheel radius under the load now: payload, and the last step's load transfer."""
    ld = w.load
    both = ld.per_kg * payload(ld.schedule, s.t) + ld.per_accel * s.accel
    outer = ld.per_lateral * s.v * s.omega  # centripetal acceleration > 0 turning left: the right wheel is outer
    return w.radius_left * (1.0 + both - outer), w.radius_right * (1.0 + both + outer)


def step(s: State, w: World, cmd_left: float, cmd_right: float, dt: float, rng: np.random.Generator) -> State:
    """The robot after dt [s] with wheel commands [rad/s]; draws the two slips from rng."""
    speed_l, turn_l = motor_step(s.speed_left, motor_target(cmd_left, w), w.motor_lag, dt)
    speed_r, turn_r = motor_step(s.speed_right, motor_target(cmd_right, w), w.motor_lag, dt)
    slip_l, slip_r = (1.0 + w.slip_sigma * rng.standard_normal(2)).tolist()
    r_left, r_right = radii(s, w) if w.load != NO_LOAD else (w.radius_left, w.radius_right)
    # The wheels turn by turn_*, which the encoders count; the ground moves by the slipped travel.
    d_left = r_left * turn_l * slip_l
    d_right = r_right * turn_r * slip_r
    ds, dtheta = (d_left + d_right) / 2.0, (d_right - d_left) / w.track
    x, y, theta = arc(s.x, s.y, s.theta, ds, dtheta)
    # Slip is a travel error per step, not a force: the accelerometer feels the motors (a wall or another
    # robot that holds the body is a force: SimRobot.step makes it feel the body's stop there).
    accel = (r_left * (speed_l - s.speed_left) + r_right * (speed_r - s.speed_right)) / (2.0 * dt)
    return State(x, y, theta, speed_l, speed_r, s.angle_left + turn_l, s.angle_right + turn_r, ds / dt, dtheta / dt, accel, s.t + dt)


def teleport(s: State, x: float | None = None, y: float | None = None, theta: float | None = None) -> State:
    """The robot put down at a new pose (unset: keep), wheels stopped; encoder angles kept."""
    return s._replace(
        x=s.x if x is None else x,
        y=s.y if y is None else y,
        theta=s.theta if theta is None else wrap_angle(theta),
        speed_left=0.0,
        speed_right=0.0,
        v=0.0,
        omega=0.0,
        accel=0.0,
    )
