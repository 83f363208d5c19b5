"""A small synthetic world for measuring the localizer without the rest of the stack.

The robot drives a square on its true pose; its wheels follow the scenario (radius
and track errors, load, slip, motor lag, deadband, encoder resolution); odometry is
integrated from the ticks with the nominal geometry; the IMU and compass have the
scenario's errors; fixes come from the VPS camera model. Returns the streams the
localizer and the scores need. Pure and seeded.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from zenav.common import messages as m
from zenav.common.config import Robot
from zenav.common.geometry import wrap_angle
from zenav.common.scenarios import Scenario
from zenav.services.vps.camera import Camera, make_rng

WORLD_STREAM = 0x574F524C44  # seed stream of the wheels, apart from the camera's


@dataclass(frozen=True)
class Run:
    """The streams of one synthetic drive."""

    truth: list[m.Truth]
    odom: list[m.Odom]
    imu: list[m.Imu]
    compass: list[m.Compass]
    fixes: list[tuple[float, m.VpsPose]]  # (arrival time [s], fix), in arrival order


def _square_command(pose: tuple[float, float, float], corner: tuple[float, float], turning: bool, speed: float):
    """(v [m/s], omega [rad/s], turning, arrived) towards a corner: turn in place, then drive."""
    x, y, th = pose
    dx, dy = corner[0] - x, corner[1] - y
    dist = math.hypot(dx, dy)
    err = wrap_angle(math.atan2(dy, dx) - th)
    if dist < 0.01 or (not turning and math.cos(err) < 0.0):
        return 0.0, 0.0, True, True
    if turning:
        if abs(err) < 0.05:
            return 0.0, 0.0, False, False
        # At least 0.8 rad/s: slower turns stall in the motors' deadband.
        return 0.0, math.copysign(max(0.8, min(2.0, 4.0 * abs(err))), err), True, False
    return min(speed, max(0.06, 2.0 * dist)), 3.0 * err, False, False


def drive_square(
    scenario: Scenario, seed: int, duration: float = 60.0, side: float = 1.0, speed: float = 0.3, robot: Robot = Robot()
) -> Run:
    """Drive the square (0,0) -> (side,0) -> (side,side) -> (0,side) -> (0,0), laps until `duration` [s]."""
    rng = np.random.default_rng([seed, WORLD_STREAM])
    camera = Camera(scenario, make_rng(seed))
    tpr = robot.ticks_per_rev or scenario.ticks_per_rev
    dt = 1.0 / scenario.sensor_rate_hz
    r, b = robot.wheel_radius, robot.track_width  # nominal [m]
    r_left = r * (1.0 + scenario.wheel_radius_err_left + scenario.load_radius_err)
    r_right = r * (1.0 + scenario.wheel_radius_err_right + scenario.load_radius_err)
    b_true = b * (1.0 + scenario.track_width_err)
    lag = 1.0 - math.exp(-dt / scenario.motor_lag) if scenario.motor_lag > 0 else 1.0
    corners = [(side, 0.0), (side, side), (0.0, side), (0.0, 0.0)]
    gyro_bias, gyro_noise = math.radians(scenario.gyro_bias_dps), math.radians(scenario.gyro_noise_dps)
    x = y = th = 0.0  # true pose
    ox = oy = oth = 0.0  # odometry
    w = [0.0, 0.0]  # wheel speeds [rad/s]
    phi = [0.0, 0.0]  # wheel angles [rad]
    ticks = [0, 0]
    v_true = 0.0
    corner, turning = 0, True
    run = Run([], [], [], [], [])
    for k in range(int(round(duration / dt)) + 1):
        t = k * dt
        ds = dth = ods = odth = 0.0
        if k > 0:
            v_cmd, om_cmd, turning, arrived = _square_command((x, y, th), corners[corner], turning, speed)
            if arrived:
                corner, turning = (corner + 1) % 4, True
            cmd = [(v_cmd - om_cmd * b / 2) / r, (v_cmd + om_cmd * b / 2) / r]
            travel = []
            for i in range(2):
                c = max(-robot.max_wheel_speed, min(robot.max_wheel_speed, cmd[i]))
                c = 0.0 if abs(c) < scenario.motor_deadband else c
                w[i] = max(-scenario.motor_max, min(scenario.motor_max, w[i] + (c - w[i]) * lag))
                phi[i] += w[i] * dt
                travel.append(w[i] * dt * (r_left, r_right)[i] * (1.0 + scenario.slip_sigma * rng.standard_normal()))
            ds, dth = (travel[0] + travel[1]) / 2, (travel[1] - travel[0]) / b_true
            x += ds * math.cos(th + dth / 2)
            y += ds * math.sin(th + dth / 2)
            th = wrap_angle(th + dth)
            new_ticks = [math.floor(p * tpr / (2 * math.pi)) for p in phi]
            dl, dr = ((new_ticks[i] - ticks[i]) * 2 * math.pi * r / tpr for i in range(2))
            ticks = new_ticks
            ods, odth = (dl + dr) / 2, (dr - dl) / b
            ox += ods * math.cos(oth + odth / 2)
            oy += ods * math.sin(oth + odth / 2)
            oth = wrap_angle(oth + odth)
        v, omega = ds / dt, dth / dt
        accel, v_true = (v - v_true) / dt, v
        run.truth.append(m.Truth(t=t, x=x, y=y, theta=th, v=v, omega=omega))
        run.odom.append(m.Odom(t=t, x=ox, y=oy, theta=oth, v=ods / dt, omega=odth / dt))
        n = rng.standard_normal(4)
        gyro = omega * (1.0 + scenario.gyro_scale_err) + gyro_bias + gyro_noise * n[0]
        ax = accel + scenario.accel_bias + scenario.accel_noise * n[1]
        ay = v * omega + scenario.accel_bias + scenario.accel_noise * n[2]
        run.imu.append(m.Imu(t=t, gyro_z=float(gyro), accel_x=float(ax), accel_y=float(ay)))
        if k % max(1, round(scenario.sensor_rate_hz / scenario.compass_rate_hz)) == 0:
            near = math.hypot(x - scenario.compass_disturbance_x, y - scenario.compass_disturbance_y)
            off = scenario.compass_disturbance_deg if near < scenario.compass_disturbance_radius else 0.0
            heading = th + math.radians(off + scenario.compass_noise_deg * float(n[3]))
            run.compass.append(m.Compass(t=t, heading=wrap_angle(heading)))
        d = camera.capture(run.truth[-1])
        if d is not None:
            run.fixes.append((d.t_delivery, d.fix))
    run.fixes.sort(key=lambda f: f[0])
    return run
