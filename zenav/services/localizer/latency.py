"""The VPS latency estimated online from the fixes and the odometry, for fixes that carry no capture stamp.

A VPS may only say that a fix is "about 300 ms" old. Each fix is kept with its
arrival time; for every candidate lag L on a grid (coarse, then fine around the
best), the odom poses at (arrival - L) are fitted to the recent fixes by one rigid
transform (rotation from the headings, translation the median offset of the
positions), and the lag with the smallest (trimmed) misfit is that window's
estimate, refined by a parabola through its neighbours, with a sigma from the
misfit's curvature. Driving straight at a constant speed leaves the lag
unobservable (a shift along the path looks the same): such windows give no estimate.
The running estimate is the inverse-variance mean of the disjoint windows of the recent
past (each window's last estimate) and of the window being filled; until the first
one it is the prior (the deployment's expected latency). The lag found is the one
relative to the odometry, which is what carrying a fix forward needs.

Pure: samples and times come in as arguments.
"""

from __future__ import annotations

import math
from collections import deque
from typing import NamedTuple, cast

import numpy as np

from zenav.common.geometry import wrap_angle

MIN_FIXES = 8  # fixes in a window before it is fitted
KEEP = 0.9  # share of the fixes (the best fitting) a misfit sums: outliers drop out
ESTIMATES = 30  # disjoint window estimates the running estimate averages
COARSE = 5  # the first search's grid, in steps


class LatencyParams(NamedTuple):
    """How the latency is searched."""

    prior: float  # [s] latency assumed until the first estimate
    prior_sigma: float  # [s] its 1 sigma
    max_lag: float  # [s] largest latency searched
    step: float  # [s] grid of the search
    window: float  # [s] fixes (by arrival) fitted together
    sigma_xy: float  # [m] 1 sigma of a fix position
    sigma_theta: float  # [rad] 1 sigma of a fix heading
    max_odom_step: float  # [m] a larger odom increment is a restart: the history starts again


class Estimate(NamedTuple):
    """The latency estimate after a fix."""

    latency: float  # [s]
    sigma: float  # [s] 1 sigma
    windows: int  # window estimates behind it (0: the prior)


class LatencyEstimator:
    """Running estimate of the capture-to-arrival latency of the VPS fixes."""

    def __init__(self, p: LatencyParams) -> None:
        self.p = p
        self.odom: deque[tuple[float, float, float, float]] = deque()  # (t [s], x, y [m], unwrapped theta [rad])
        self.fixes: deque[tuple[float, float, float, float]] = deque()  # (arrival [s], x, y [m], theta [rad])
        self.windows: deque[tuple[float, float]] = deque(maxlen=ESTIMATES)  # (lag [s], sigma [s]) of disjoint windows
        self.current: tuple[float, float] | None = None  # (lag [s], sigma [s]) of the window being filled
        self.t_window = -math.inf  # [s] arrival time the window being filled started
        self.estimate = Estimate(p.prior, p.prior_sigma, 0)

    def on_odom(self, t: float, x: float, y: float, theta: float) -> None:
        """One odom sample (odom frame), newer than the previous one."""
        if self.odom:
            t0, x0, y0, th0 = self.odom[-1]
            if math.hypot(x - x0, y - y0) > self.p.max_odom_step:
                self.odom.clear()
            else:
                theta = th0 + wrap_angle(theta - th0)
        self.odom.append((t, x, y, theta))
        horizon = t - self.p.window - self.p.max_lag - 1.0
        while len(self.odom) > 2 and self.odom[1][0] < horizon:
            self.odom.popleft()

    def on_fix(self, t_arrival: float, x: float, y: float, theta: float) -> Estimate:
        """One fix (map frame) arrived at t_arrival [s]: the estimate with it."""
        self.fixes.append((t_arrival, x, y, theta))
        while self.fixes[0][0] < t_arrival - self.p.window:
            self.fixes.popleft()
        w = self.fit()
        if w is None:
            return self.estimate
        self.current = w
        if t_arrival - self.t_window >= self.p.window:  # the window is full: it counts on its own from now on
            self.windows.append(w)
            self.current, self.t_window = None, t_arrival
        lags, sigmas = np.array([*self.windows, *([self.current] if self.current else [])]).T
        weights = 1.0 / sigmas**2
        mean = float(np.sum(weights * lags) / np.sum(weights))
        n = len(lags)
        # The scatter of the windows bounds their sigmas from below when the sigmas are too small.
        spread = float(np.sqrt(np.sum(weights * (lags - mean) ** 2) / np.sum(weights) / max(1, n - 1)))
        self.estimate = Estimate(mean, max(float(np.sqrt(1.0 / np.sum(weights))), spread), n)
        return self.estimate

    def misfit(self, lags: np.ndarray) -> np.ndarray:
        """The trimmed misfit [-] of the window's fixes at each lag [s] (odom covering arrival - lags)."""
        ft, fx, fy, fth = np.array(self.fixes).T
        ot, ox, oy, oth = np.array(self.odom).T
        tq = np.minimum(ft[None, :] - lags[:, None], ot[-1])  # (lags, fixes); a fix newer than odom: the newest pose
        qx, qy, qth = np.interp(tq, ot, ox), np.interp(tq, ot, oy), np.interp(tq, ot, oth)
        dth = np.angle(np.exp(1j * (fth[None, :] - qth)))
        rot = np.angle(np.mean(np.exp(1j * dth), axis=1))  # (lags,) map heading of the odom x axis
        res_th = np.angle(np.exp(1j * (dth - rot[:, None])))
        c, s = np.cos(rot)[:, None], np.sin(rot)[:, None]
        px, py = c * qx - s * qy, s * qx + c * qy  # odom positions rotated into the map
        ex, ey = fx[None, :] - px, fy[None, :] - py
        ex -= np.median(ex, axis=1, keepdims=True)  # the translation: the median offset (outliers drop out)
        ey -= np.median(ey, axis=1, keepdims=True)
        cost = (ex**2 + ey**2) / self.p.sigma_xy**2 + res_th**2 / self.p.sigma_theta**2
        kept = max(MIN_FIXES, math.ceil(KEEP * cost.shape[1]))
        return cast(np.ndarray, np.sort(cost, axis=1)[:, :kept].sum(axis=1))

    def fit(self) -> tuple[float, float] | None:
        """(lag [s], sigma [s]) of the current window, or None when it does not show the lag.

        The lag is searched on a grid COARSE times the step, then on the step around the best."""
        if len(self.fixes) < MIN_FIXES or len(self.odom) < 2:
            return None
        step = self.p.step
        top = min(self.p.max_lag, self.fixes[0][0] - self.odom[0][0])  # [s] the largest lag the odometry covers
        if top < COARSE * step:
            return None
        coarse = np.arange(0.0, top + 1e-9, COARSE * step)
        k = int(np.argmin(self.misfit(coarse)))
        lags = np.arange(max(0.0, coarse[k] - COARSE * step), min(top, coarse[k] + COARSE * step) + 1e-9, step)
        cost = self.misfit(lags)
        k = int(np.argmin(cost))
        if k == 0 or k == len(lags) - 1:
            return None  # at the edge of the search: no minimum seen
        a, b, c = cost[k - 1], cost[k], cost[k + 1]
        curv = (a - 2.0 * b + c) / step**2  # [1/s^2]
        if curv <= 0.0:
            return None
        lag = float(lags[k] + 0.5 * (a - c) / (a - 2.0 * b + c) * step)
        n = min(len(self.fixes), max(MIN_FIXES, math.ceil(KEEP * len(self.fixes))))
        chi2 = max(1.0, float(b) / max(1, 3 * n - 4))  # misfit per degree of freedom: scales a sigma too small
        sigma = math.sqrt(2.0 * chi2 / curv)
        if sigma > self.p.prior_sigma:
            return None  # the window hardly constrains the lag (straight, constant speed)
        return lag, sigma
