"""The default mode: an EKF with a time-indexed history that applies late fixes at capture time.

Every odom sample extends the history's newest step (t, increment, state, covariance)
by its increment, or begins a new step once that one spans `history_samples` samples:
each sample's pose is predicted from the step before over the whole increment since,
and a late fix re-integrates a step, not each sample, since its capture. A fix
captured at t_c is compared with the state interpolated at t_c, gated by its
Mahalanobis distance, inserted there, and the history is re-integrated forward to
the newest sample. A long run of rejected fixes means the filter, not the camera, is
wrong: the pose covariance is inflated and a fix that the previous one confirms
re-acquires; the filter starts the same way, from two agreeing fixes, and uses
both. The state carries the odometry's and the gyro's calibration errors, which
the fixes make observable. Gyro samples that come after their odom sample
are filled into the history the same way. While the wheels are found slipping (by the
fixes, or at once by the accelerometer: impact.py) their travel weighs little.
"""

from __future__ import annotations

import bisect
import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from zenav.common import messages as m
from zenav.common.config import RobotConfig
from zenav.common.geometry import Pose2, wrap_angle

from . import impact, model
from .base import FixResult, LocalizerConfig, Mode, fix_cov
from .gyro import GyroIntegral


@dataclass
class _Fix:
    t: float  # [s] capture
    z: np.ndarray  # (x, y, theta)
    R: np.ndarray  # 3x3
    reacquire: bool = False  # forget the pose before applying it


TRACTION_WINDOW = 0.5  # [s] of fixes over which the wheels' traction is judged
TRACTION_TRAVEL = 0.08  # [m] of odometry travel over it, at least, to judge it (the fixes' noise is ~0.02 m)
TRACTION = 0.5  # [-] the fixes moved less than this share of the odometry's travel: the wheels slip
# [s] no fix for this long: the fixes stopped (the camera lost the robot). The odometry ran alone
# meanwhile, so fixes that disagree once they come back re-acquire its drift, not a slip.
FIX_GAP = 1.0


@dataclass
class _Candidate:
    t: float  # [s] capture
    z: np.ndarray  # an unused fix (x, y, theta)
    R: np.ndarray
    s: list[float]  # the filter's pose (x, y, theta) at its capture time


@dataclass
class _Entry:
    t: float  # [s] time of the newest odom sample it spans
    u: model.Step  # the increment from the previous entry
    s: model.Vec  # state after the increment and the fixes captured in (previous t, t]
    P: model.Mat
    fixes: list[_Fix] = field(default_factory=list)  # accepted, by capture time
    samples: int = 1  # odom samples the increment spans
    closed: bool = False  # takes no more samples (a fix was applied to its state in place)


def _forget(P: model.Mat, rows: Sequence[int], variances: Sequence[float]) -> model.Mat:
    """A copy of P with each of `rows` uncorrelated, its variance the matching one of `variances`."""
    out = [row[:] for row in P]
    for i, v in zip(rows, variances):
        for j in range(model.N):
            out[i][j] = out[j][i] = 0.0
        out[i][i] = v
    return out


class Ekf(Mode):
    """Delayed-fix EKF with replay, gating, recovery and online calibration (`delayed=False`: fixes as if current)."""

    sensors = ("sensors/imu",)

    def __init__(self, cfg: LocalizerConfig, robot: RobotConfig, delayed: bool = True) -> None:
        super().__init__(cfg, robot)
        self.delayed = delayed
        self.history: list[_Entry] = []  # oldest first; the first entry is at or before the horizon
        self.rejections = 0  # consecutive rejected fixes
        self.initialised = False  # a fix or a full set_pose has placed the robot in the map
        self.candidate: _Candidate | None = None  # the newest unused fix, to confirm the next one
        self.heard: float | None = None  # [s] capture time of the newest fix heard, used or not
        self.after_gap = False  # the rejections in a row began after FIX_GAP without a fix
        self.gyro = GyroIntegral(cfg.history, cfg.gyro_max_gap)
        self.gyro_used = False
        tick = 2.0 * math.pi * robot.wheel_radius / (robot.ticks_per_rev or 360)
        self.noise = model.Noise(robot.track_width, tick, cfg.wheel_noise, cfg.calib_noise, cfg.gyro_noise**2, cfg.gyro_bias_noise**2)
        self._unknown = (cfg.unknown_sigma_xy**2, cfg.unknown_sigma_xy**2, math.pi**2)  # pose variances when lost
        self.slip = (math.inf, -math.inf)  # [s] (from, until): the wheels found slipping over this span of odometry
        self.recent: deque[tuple[float, float, float]] = deque()  # (t, x, y) of the fixes over the last TRACTION_WINDOW
        self.short = False  # the last fix moved too little for the odometry's travel
        span = impact.window(cfg.impact_speed, tick) if cfg.impact_speed > 0.0 and cfg.slip_noise > 0.0 else None
        self.impact: impact.Impact | None = None  # the accelerometer's check (None: not read)
        if span is not None:
            at = (robot.imu_x, robot.imu_y)
            self.impact = impact.Impact(cfg.impact_speed, cfg.impact_leak, span, cfg.history, cfg.gyro_max_gap, at)

    # ------------------------------------------------------------ filter steps
    def _apply(self, s: model.Vec, P: model.Mat, f: _Fix) -> tuple[model.Vec, model.Mat]:
        if f.reacquire:
            P = _forget(P, (model.X, model.Y, model.TH), self._unknown)
        nu, S, _ = model.innovation(s, P, f.z, f.R)
        return model.update(s, P, nu, S, f.R)

    def _predict(self, s: model.Vec, P: model.Mat, u: model.Step, t: float) -> tuple[model.Vec, model.Mat]:
        """Propagate through an increment that ends at t [s]; while the wheels slip, its travel says little
        of where the robot went (slip_noise per metre, on x and y), so that the fixes say it."""
        s, P = model.predict(s, P, u, self.noise)
        if self.slip[0] < t <= self.slip[1]:
            q = self.cfg.slip_noise * abs(u.ds)
            P[model.X][model.X] += q
            P[model.Y][model.Y] += q
        return s, P

    def _slipping(self, t: float, z: np.ndarray, reacquired: bool) -> bool:
        """Whether the fix z at t [s] finds the wheels slipping, and for how long; True if that changed the
        span the odometry is not trusted over. They slip where the fixes of the last TRACTION_WINDOW moved
        less than TRACTION of the odometry's travel (at least TRACTION_TRAVEL), as two fixes in a row see
        it, or where a fix re-acquired the robot away from where the odometry took it. It lasts slip_hold
        after the last fix that found it, from the first."""
        if self.cfg.slip_noise == 0.0:  # never found slipping: nothing to judge
            return False
        self.recent.append((t, float(z[0]), float(z[1])))
        while self.recent[0][0] < t - TRACTION_WINDOW:
            self.recent.popleft()
        slipping = reacquired
        t0, x0, y0 = self.recent[0]
        if not slipping and t - t0 >= TRACTION_WINDOW / 2.0:
            first = bisect.bisect_right(self.history, t0, key=lambda e: e.t)
            last = bisect.bisect_right(self.history, t, key=lambda e: e.t)
            travel = sum(abs(e.u.ds) for e in self.history[first:last])
            short = travel >= TRACTION_TRAVEL and math.hypot(z[0] - x0, z[1] - y0) < TRACTION * travel
            slipping, self.short = short and self.short, short  # two fixes in a row: not one outlier
        if not slipping:
            return False
        before = self.slip
        self._slip(t, t)
        return self.slip != before

    def _slip(self, start: float, t: float) -> bool:
        """The wheels found slipping at t [s]: the span lasts slip_hold past t, from `start` if it is new (True)."""
        going = self.slip[0] <= t <= self.slip[1]
        self.slip = (self.slip[0] if going else start, t + self.cfg.slip_hold)
        return not going

    def _advance(self, s: model.Vec, P: model.Mat, t0: float, e: _Entry, until: float = math.inf) -> tuple[model.Vec, model.Mat]:
        """Integrate entry e's increment from time t0, applying its fixes, up to `until` [s]."""
        end = min(e.t, until)
        span = e.t - t0
        done = 0.0  # fraction of the increment integrated so far
        for f in e.fixes:
            if f.t > end:
                break
            frac = (f.t - t0) / span
            s, P = self._predict(s, P, e.u.part(frac - done), f.t)
            s, P = self._apply(s, P, f)
            done = frac
        frac = (end - t0) / span
        if frac > done:
            s, P = self._predict(s, P, e.u if done == 0.0 and frac == 1.0 else e.u.part(frac - done), end)
        return s, P

    def _replay(self, k: int) -> None:
        """Recompute entries k.. from entry k-1."""
        for i in range(k, len(self.history)):
            prev, e = self.history[i - 1], self.history[i]
            e.s, e.P = self._advance(prev.s, prev.P, prev.t, e)

    def _agrees(self, a: _Candidate | None, b: _Candidate) -> bool:
        """Whether fix b is where fix a and the odometry since a say the robot is."""
        if a is None:
            return False
        pred = Pose2(*a.z).compose(Pose2(*a.s).between(Pose2(*b.s)))
        nu = b.z - np.array(pred)
        nu[2] = wrap_angle(nu[2])
        return float(nu @ np.linalg.solve(a.R + b.R, nu)) <= self.cfg.gate

    # ------------------------------------------------------------ mode hooks
    def on_imu(self, imu: m.Imu) -> str | None:
        if not self.gyro.add(imu.t, imu.gyro_z):
            return "stale"
        if self.impact is not None:
            self.impact.on_imu(imu.t, imu.accel_x, imu.accel_y, imu.gyro_z)
        if not self.history:
            return None
        first = None  # fill the increments the gyro now covers, then re-integrate from there
        for i in range(len(self.history) - 1, 0, -1):
            e = self.history[i]
            start = e.t - e.u.dt
            if e.u.gyro is not None or start < self.gyro.t[0]:
                break
            g = self.gyro.between(start, e.t)
            if g is not None:
                e.u = replace(e.u, gyro=g)
                first = i
        if first is not None:
            self.gyro_used = True
            self._replay(first)
        return None

    def _start(self, pose: Pose2) -> None:
        calib, bias = self.cfg.calib_sigma**2, self.cfg.gyro_bias_sigma**2
        variances = (*self._unknown, calib, calib, calib, bias, calib, model.rounding_var(self.noise))  # x y theta es ew ed bg sg ro
        P = [[v if i == j else 0.0 for j in range(model.N)] for i, v in enumerate(variances)]
        self.history = [_Entry(self.last.t, model.Step(0.0, 0.0, 0.0), [*pose, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], P)]

    def _move(self, ds: float, dth: float, t0: float, t: float) -> None:
        unmeasured = (self.last.unmeasured_left**2, self.last.unmeasured_right**2)
        last = self.history[-1]
        if len(self.history) > 1 and last.samples < self.cfg.history_samples and not last.closed:
            # The newest step takes this sample too: predicted again from the step before, over both.
            prev, u = self.history[-2], last.u
            g = self.gyro.between(prev.t, t)
            last.u = model.Step(u.ds + ds, u.dth + dth, t - prev.t, g, (u.unmeasured[0] + unmeasured[0], u.unmeasured[1] + unmeasured[1]))
            last.t, last.samples = t, last.samples + 1
            last.s, last.P = self._advance(prev.s, prev.P, prev.t, last)
        else:
            g = self.gyro.between(t0, t)
            u = model.Step(ds, dth, t - t0, g, unmeasured)
            s, P = self._predict(last.s, last.P, u, t)
            self.history.append(_Entry(t, u, s, P))
        self.gyro_used = self.gyro_used or g is not None
        drop = bisect.bisect_left(self.history, t - self.cfg.history, key=lambda e: e.t)
        if drop > 1:
            del self.history[: drop - 1]
        if self.impact is not None and self.impact.on_odom(t0, t, ds):
            # The accelerometer found it, half its window back: the increments from there are re-weighed as slipping.
            start = t - self.impact.window / 2.0
            if self._slip(start, t):
                self.impacts += 1
                self._replay(max(bisect.bisect_right(self.history, start, key=lambda e: e.t), 1))

    def _fix(self, fix: m.VpsPose, t: float, t_arrival: float) -> FixResult:
        z = np.array([fix.x, fix.y, fix.theta])
        R = fix_cov(fix, self.cfg)
        if self.delayed:
            if t < self.history[0].t:
                return FixResult(False, "too_old")
            k = bisect.bisect_left(self.history, t, key=lambda e: e.t)
        else:  # as if captured at the newest sample
            k = len(self.history) - 1
            t = self.history[k].t
        e = self.history[k]
        if self._in_place(k):
            s, P = e.s, e.P
        else:
            prev = self.history[k - 1]
            s, P = self._advance(prev.s, prev.P, prev.t, e, t)
        R = R + model.rounding_cov(self.noise, s[model.TH], heading=e.u.gyro is None)
        gap = self.heard is None or t - self.heard > FIX_GAP
        self.heard = t if self.heard is None else max(self.heard, t)
        nu, S, d2 = model.innovation(s, P, z, R)
        innovation = (float(nu[0]), float(nu[1]), float(nu[2]))
        reason = "accepted"
        if not self.initialised or d2 > self.cfg.gate:
            # Start (again) only from a fix the previous unused one agrees with: never from a lone outlier.
            candidate, self.candidate = self.candidate, _Candidate(t, z, R, s[:3])
            confirmed = self._agrees(candidate, self.candidate)
            if not self.initialised:
                if not confirmed:
                    return FixResult(False, "unconfirmed", innovation, d2)
                reason = "initialised"
            else:
                if self.rejections == 0:
                    self.after_gap = gap
                self.rejections += 1
                if self.rejections < self.cfg.recover_after or not confirmed:
                    if self._slipping(t, z, False):  # the odometry, not the fix, is wrong: the next one is weighed so
                        self._replay(k)
                    return FixResult(False, "outlier", innovation, d2)
                reason = "reacquired"
        self.rejections, self.candidate, self.initialised = 0, None, True
        # Re-acquired while the fixes kept coming: the robot went where the odometry did not take it (a push,
        # a hold). Re-acquired as they came back after a gap: the odometry drifted meanwhile.
        self._slipping(t, z, reason == "reacquired" and not self.after_gap)
        first = len(self.history)
        if reason == "initialised" and candidate is not None and self.delayed and candidate.t >= self.history[0].t:
            # The fix this one confirmed is as good: used too, at its capture time (before this one's).
            j = bisect.bisect_left(self.history, candidate.t, key=lambda e: e.t)
            first = self._insert(_Fix(candidate.t, candidate.z, candidate.R), j)
        first = min(first, self._insert(_Fix(t, z, R, reacquire=reason == "reacquired"), k))
        self._replay(first)
        return FixResult(True, reason, innovation, d2, sum(e.samples for e in self.history[first:]))

    def _in_place(self, k: int) -> bool:
        """Whether a fix in history entry k is at the entry's own time (applied to its state, not between steps)."""
        return k == 0 or not self.delayed

    def _insert(self, f: _Fix, k: int) -> int:
        """Put fix f in history entry k (the one its capture time falls in); the first entry to re-integrate."""
        e = self.history[k]
        if self._in_place(k):
            e.s, e.P = self._apply(e.s, e.P, f)
            e.closed = True  # re-predicted from the step before, its state would lose the fix
            return k + 1
        bisect.insort(e.fixes, f, key=lambda x: x.t)
        return k

    def _set(self, x: float | None, y: float | None, theta: float | None) -> None:
        last = self.history[-1]
        s, rows, variances = last.s[:], [], []
        for i, value, sigma in (
            (model.X, x, self.cfg.set_pose_sigma_xy),
            (model.Y, y, self.cfg.set_pose_sigma_xy),
            (model.TH, theta, self.cfg.set_pose_sigma_theta),
        ):
            if value is not None:
                s[i] = value
                rows.append(i)
                variances.append(sigma**2)
        P = _forget(last.P, rows, variances)
        self.initialised = self.initialised or None not in (x, y, theta)
        self.rejections, self.candidate = 0, None
        self.history = [_Entry(last.t, model.Step(0.0, 0.0, 0.0), s, P)]

    def _estimate(self) -> tuple[Pose2, tuple[float, ...]]:
        e = self.history[-1]
        x, y, theta = e.s[:3]
        P = e.P
        return Pose2(x, y, theta), (*P[0][:3], *P[1][:3], *P[2][:3])

    def calibration(self) -> dict[str, float]:
        e = self.history[-1]
        return model.calibration(e.s, e.P, self.robot.track_width, self.robot.wheel_radius, self.gyro_used)

    def slipping(self) -> bool:
        return self.odom is not None and self.slip[0] < self.odom.t <= self.slip[1]
