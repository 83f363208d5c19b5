"""UMBmark: the track width and the wheels' radius ratio from squares driven both ways (pure).

The robot drives a square of side L by its own encoder dead reckoning on the nominal
geometry, clockwise and counter-clockwise, and the end position is measured (VPS, or
a tape on the floor). The error (measured minus dead-reckoned, in the start frame: x
along the first leg, y to its left) has two systematic causes (Borenstein & Feng,
1996): a track width that is not the nominal one (turns over- or under-shoot) and
wheels of unequal radii (straight legs curve). `fit` finds both by least squares on
the exact model of each run as its encoders counted it (`end_error`), without the
paper's small-angle forms or its assumption that every turn and leg ended exactly.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from zenav.common.geometry import wrap_angle

LEGS = 4
FIT_STEPS = 30  # Gauss-Newton iterations at most
FIT_TOL = 1e-12  # stop when a step moves the parameters less than this


class Geometry(NamedTuple):
    """A differential drive's wheel geometry."""

    track: float  # [m] wheel contact to contact
    radius_left: float  # [m]
    radius_right: float  # [m]


class Fit(NamedTuple):
    """What the squares say about the robot."""

    geometry: Geometry  # the fitted geometry (the mean radius kept: squares cannot see a scale error)
    track_scale: float  # true track / nominal [-]
    ratio: float  # right radius / left radius [-]
    rms: float  # [m] end errors the fitted model leaves unexplained (slip, noise, measuring)


def _arc(x: float, y: float, th: float, ds: float, dth: float) -> tuple[float, float, float]:
    h = dth / 2.0
    chord = ds * (math.sin(h) / h if abs(h) > 1e-9 else 1.0)
    return x + chord * math.cos(th + h), y + chord * math.sin(th + h), th + dth


class Run(NamedTuple):
    """One square as driven: what the encoders counted, and where it ended."""

    clockwise: bool
    trace: Sequence[tuple[float, float]]  # (left, right) wheel distance [m] counted each step, on the nominal radii
    error: tuple[float, float]  # [m] measured end minus dead-reckoned end, in the start frame


def square(side: float, clockwise: bool, track: float) -> list[tuple[float, float]]:
    """The trace of a square of `side` [m] driven perfectly by the nominal odometry of `track` [m]: legs
    counted `side`, turns in place counted +-90 deg (what a run typed in by hand is assumed to be)."""
    arc = math.pi / 4.0 * track * (-1.0 if clockwise else 1.0)  # each wheel's distance in a turn
    return [(side, side), (-arc, arc)] * LEGS


def _end(left: np.ndarray, right: np.ndarray, track: float) -> np.ndarray:
    """Where wheel distances `left`, `right` [m] per step (each an arc) take a robot of `track` [m]: (x, y)."""
    ds, dth = (left + right) / 2.0, (right - left) / track
    before = np.concatenate(([0.0], np.cumsum(dth)[:-1]))  # heading at the start of each step
    chord = ds * np.sinc(dth / (2.0 * np.pi))  # sin(h) / h, h = dth / 2
    return np.array([np.sum(chord * np.cos(before + dth / 2.0)), np.sum(chord * np.sin(before + dth / 2.0))])


def end_error(trace: Sequence[tuple[float, float]] | np.ndarray, track_scale: float, ratio: float, track: float) -> tuple[float, float]:
    """The end error [m] (true end minus dead-reckoned end, start frame) of a run that counted `trace` on the
    nominal `track` [m], when the true track is `track_scale` x nominal and right/left radius is `ratio` (mean kept)."""
    d = np.asarray(trace, dtype=float).reshape(-1, 2)
    k_left, k_right = 2.0 / (1.0 + ratio), 2.0 * ratio / (1.0 + ratio)  # true radius / nominal
    e = _end(d[:, 0] * k_left, d[:, 1] * k_right, track * track_scale) - _end(d[:, 0], d[:, 1], track)
    return float(e[0]), float(e[1])


def fit(runs: Sequence[Run], nominal: Geometry) -> Fit:
    """The geometry that explains the end errors of `runs`, clockwise and counter-clockwise. The model
    replays each run's own trace, so a run that over- or under-shot a turn or a leg is fitted as driven."""
    if {run.clockwise for run in runs} != {True, False}:
        raise ValueError("UMBmark needs at least one clockwise and one counter-clockwise run")
    measured = np.array([v for run in runs for v in run.error], dtype=float)
    traces = [np.asarray(run.trace, dtype=float).reshape(-1, 2) for run in runs]  # once, not at every evaluation

    def model(q: np.ndarray) -> np.ndarray:
        return np.array([v for d in traces for v in end_error(d, q[0], q[1], nominal.track)])

    q = np.array([1.0, 1.0])  # (track_scale, ratio): the nominal robot
    for _ in range(FIT_STEPS):
        r = model(q) - measured
        jac = np.empty((len(r), 2))
        for i in range(2):
            h = np.zeros(2)
            h[i] = 1e-7
            jac[:, i] = (model(q + h) - model(q - h)) / 2e-7
        step = np.linalg.lstsq(jac, -r, rcond=None)[0]
        q = q + step
        if not np.all(np.isfinite(q)) or q[0] <= 0.0 or q[1] <= 0.0:
            raise ValueError("the end errors fit no plausible robot: check their signs (x along the first leg, y to its left)")
        if float(np.max(np.abs(step))) < FIT_TOL:
            break
    scale, ratio = float(q[0]), float(q[1])
    mean_r = (nominal.radius_left + nominal.radius_right) / 2.0
    geometry = Geometry(nominal.track * scale, mean_r * 2.0 / (1.0 + ratio), mean_r * 2.0 * ratio / (1.0 + ratio))
    rms = float(np.sqrt(np.mean((model(q) - measured) ** 2)))
    return Fit(geometry, scale, ratio, rms)


class Square:
    """Drives a square by encoder dead reckoning on the nominal geometry: counts in, (v, omega) out.

    Legs hold the heading and slow down near their end; turns are in place. `pose` is
    where the robot believes it is, from the start (x along the first leg).
    """

    def __init__(
        self,
        side: float,  # [m]
        clockwise: bool,
        nominal: Geometry,
        ticks_per_rev: int,
        speed: float = 0.15,  # [m/s] top speed of a leg
        turn_rate: float = 1.0,  # [rad/s] top rate of a turn
        gain: float = 3.0,  # [1/s] speed per remaining distance (m) or angle (rad) near a target
        tolerance: float = math.radians(0.5),  # [rad] a turn is done this close
    ) -> None:
        self.side, self.nominal = side, nominal
        self.turn = -math.pi / 2.0 if clockwise else math.pi / 2.0
        self.per_tick = 2.0 * math.pi / ticks_per_rev  # [rad] of wheel per tick
        self.speed, self.turn_rate, self.gain, self.tolerance = speed, turn_rate, gain, tolerance
        self.pose = (0.0, 0.0, 0.0)  # [m, m, rad] believed
        self.phase = 0  # even: leg phase // 2, odd: the turn after it
        self.heading = 0.0  # [rad] the heading the current phase holds or turns to (unwrapped)
        self.leg_start = (0.0, 0.0)
        self.last: tuple[int, int] | None = None
        self.trace: list[tuple[float, float]] = []  # (left, right) [m] counted at each step

    @property
    def done(self) -> bool:
        return self.phase >= 2 * LEGS

    def step(self, left: int, right: int) -> tuple[float, float]:
        """One encoder sample (cumulative ticks): the body command (v [m/s], omega [rad/s]) to send now."""
        if self.last is not None:
            dl = ((left - self.last[0] + 2**31) % 2**32 - 2**31) * self.per_tick * self.nominal.radius_left
            dr = ((right - self.last[1] + 2**31) % 2**32 - 2**31) * self.per_tick * self.nominal.radius_right
            self.trace.append((dl, dr))
            self.pose = _arc(*self.pose, (dl + dr) / 2.0, (dr - dl) / self.nominal.track)
        self.last = (left, right)
        while not self.done:
            x, y, th = self.pose
            err = wrap_angle(self.heading - th)
            if self.phase % 2 == 0:
                along = (x - self.leg_start[0]) * math.cos(self.heading) + (y - self.leg_start[1]) * math.sin(self.heading)
                remaining = self.side - along
                if remaining > 0.0:
                    v = min(self.speed, self.gain * remaining + 0.02)
                    return v, max(-self.turn_rate, min(self.turn_rate, self.gain * err))
                self.heading += self.turn
            else:
                if abs(err) > self.tolerance:
                    rate = min(self.turn_rate, self.gain * abs(err) + 0.1)
                    return 0.0, math.copysign(rate, err)
                self.leg_start = (x, y)
            self.phase += 1
        return 0.0, 0.0
