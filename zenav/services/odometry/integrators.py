"""Pose integrators for one odometry step: travel d [m] while the heading turns by dtheta [rad].

Over one encoder step v and omega are taken as constant (v*dt = d, omega*dt = dtheta),
so no integrator needs dt. Each integrator gives the step's displacement per metre
travelled, (a, b): x += d*a, y += d*b, and the derivatives of a and b by dtheta; `step`
applies it and returns the Jacobians that carry the covariance. Every (a, b) is a
rotation of a vector that depends on dtheta only, so d(a, b)/dtheta_old = (-b, a).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

from zenav.common.geometry import wrap_angle


class Direction(NamedTuple):
    """Displacement per metre travelled over one step, world frame, and its dtheta derivatives."""

    a: float  # x per metre [-]
    b: float  # y per metre [-]
    da: float  # d a / d dtheta [1/rad]
    db: float  # d b / d dtheta [1/rad]


Integrator = Callable[[float, float], Direction]  # (theta_old [rad], dtheta [rad]) -> Direction


def euler(theta: float, dtheta: float) -> Direction:
    """Euler: the whole step along the old heading."""
    return Direction(math.cos(theta), math.sin(theta), 0.0, 0.0)


def midpoint(theta: float, dtheta: float) -> Direction:
    """The whole step along the heading at mid-step."""
    c, s = math.cos(theta + dtheta / 2.0), math.sin(theta + dtheta / 2.0)
    return Direction(c, s, -s / 2.0, c / 2.0)


def rk4(theta: float, dtheta: float) -> Direction:
    """Fourth-order Runge-Kutta on (v cos theta, v sin theta, omega)."""
    # Seed: k00 = v cos(th), k10 = v cos(th + t/2 k02), k20 = v cos(th + t/2 k12),
    # k30 = v cos(th + t k22), k02 = k12 = k22 = omega; x += t/6 (k00 + 2 (k10 + k20) + k30).
    # With v t = d and omega t = dtheta, k10 = k20 and the per-metre terms are these.
    c0, s0 = math.cos(theta), math.sin(theta)
    c1, s1 = math.cos(theta + dtheta / 2.0), math.sin(theta + dtheta / 2.0)  # k10, k20
    c3, s3 = math.cos(theta + dtheta), math.sin(theta + dtheta)  # k30
    return Direction(
        (c0 + 2.0 * (c1 + c1) + c3) / 6.0,
        (s0 + 2.0 * (s1 + s1) + s3) / 6.0,
        -(2.0 * s1 + s3) / 6.0,
        (2.0 * c1 + c3) / 6.0,
    )


_SERIES = 1e-3  # [rad] below this half-turn, sin(h)/h by its series (relative error < 1e-22)


def arc(theta: float, dtheta: float) -> Direction:
    """The exact circular arc, i.e. its chord; a straight line when dtheta -> 0."""
    h = dtheta / 2.0
    if abs(h) > _SERIES:
        k = math.sin(h) / h  # chord length per arc length
        dk = (h * math.cos(h) - math.sin(h)) / (h * h)
    else:
        h2 = h * h
        k = 1.0 - h2 / 6.0 + h2 * h2 / 120.0
        dk = -h / 3.0 + h * h2 / 30.0
    c, s = math.cos(theta + h), math.sin(theta + h)
    return Direction(k * c, k * s, (dk * c - k * s) / 2.0, (dk * s + k * c) / 2.0)


INTEGRATORS: dict[str, Integrator] = {"euler": euler, "midpoint": midpoint, "rk4": rk4, "arc": arc}


class Step(NamedTuple):
    """A pose after one step, with the Jacobians of the step."""

    x: float  # [m]
    y: float  # [m]
    theta: float  # [rad] wrapped
    F: tuple[tuple[float, float, float], ...]  # 3x3 rows: d(x, y, theta)_new / d(x, y, theta)_old
    G: tuple[tuple[float, float], ...]  # 3x2 rows: d(x, y, theta)_new / d(d, dtheta)


def step(x: float, y: float, theta: float, d: float, dtheta: float, integrator: Integrator) -> Step:
    """Advance the pose by travel d [m] and heading change dtheta [rad]."""
    a, b, da, db = integrator(theta, dtheta)
    F = ((1.0, 0.0, -d * b), (0.0, 1.0, d * a), (0.0, 0.0, 1.0))
    G = ((a, d * da), (b, d * db), (0.0, 1.0))
    return Step(x + d * a, y + d * b, wrap_angle(theta + dtheta), F, G)
