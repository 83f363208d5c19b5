"""The default mode: delayed-fix EKF with replay, gating, recovery, calibration, set_pose."""

import math

import msgspec
import numpy as np
import pytest

from zenav.bench.studies.localizer import drive_square, evaluate
from zenav.common import messages as m
from zenav.common.config import RobotConfig
from zenav.common.geometry import Pose2, wrap_angle
from zenav.common.scenarios import scenario
from zenav.services.localizer.base import LocalizerConfig
from zenav.services.localizer.ekf import Ekf

ROBOT = RobotConfig(ticks_per_rev=360)
COV = (0.02**2, 0.0, 0.0, 0.0, 0.02**2, 0.0, 0.0, 0.0, 0.035**2)


@pytest.fixture(scope="module")
def default_run():
    return drive_square(scenario("default"), 7)


@pytest.fixture(scope="module")
def default_scored(default_run):
    """The default filter after the default run, and its score."""
    r = default_run
    ekf = Ekf(LocalizerConfig(), ROBOT)
    return ekf, evaluate(ekf, r.odom, r.fixes, r.truth, r.imu)


@pytest.fixture(scope="module")
def harsh_run():
    return drive_square(scenario("harsh"), 7)


def straight(ekf: Ekf, t_from: float, t_to: float, v: float = 0.3, y: float = 0.0, accel=None):
    """Perfect odometry along x at v [m/s], 100 Hz, from the origin at t = 0; `accel`: an IMU sample before each
    odom sample, the accelerometer's forward reading accel(t) [m/s^2] and no turn."""
    for k in range(int(round(t_from * 100)), int(round(t_to * 100)) + 1):
        t = k / 100
        if accel is not None:
            ekf.on_imu(m.Imu(t=t, gyro_z=0.0, accel_x=accel(t), accel_y=0.0))
        ekf.on_odom(m.Odom(t=t, x=v * t, y=y, theta=0.0, v=v, omega=0.0))


def fix(t: float, x: float, y: float = 0.0, theta: float = 0.0) -> m.VpsPose:
    return m.VpsPose(t=t, x=x, y=y, theta=theta, cov=COV)


def tracking(t_end: float = 3.0, accel=None, **cfg) -> Ekf:
    """A filter initialised by two fixes and driven along x to t_end, fixes 0.3 s late (`accel`: as `straight`)."""
    ekf = Ekf(LocalizerConfig(**cfg), ROBOT)
    straight(ekf, 0.0, 0.5, accel=accel)
    for tc in (0.1, 0.2):
        ekf.on_fix(fix(tc, 0.3 * tc), 0.5)
    for k in range(6, int(t_end * 100) + 1):
        t = k / 100
        straight(ekf, t, t, accel=accel)
        if k % 10 == 5:  # fixes captured at x.x5 s: the tests send their own at x.x0
            ekf.on_fix(fix(t - 0.3, 0.3 * (t - 0.3)), t)
    return ekf


def test_tracks_truth_on_default(default_scored):
    s = default_scored[1]
    assert s.rmse < 0.01 and s.max < 0.04 and s.outliers_accepted == 0


def test_tracks_truth_through_the_outage_on_harsh(harsh_run):
    r = harsh_run
    robot = RobotConfig(ticks_per_rev=16)
    s = evaluate(Ekf(LocalizerConfig(), robot), r.odom, r.fixes, r.truth, r.imu, outage=(20.0, 30.0))
    assert s.rmse < 0.025 and s.outage_end < 0.04 and s.outliers_accepted == 0
    no_imu = evaluate(Ekf(LocalizerConfig(), robot), r.odom, r.fixes, r.truth, outage=(20.0, 30.0))
    assert no_imu.rmse < 0.04  # without the gyro too, only less well


def test_learns_the_odometry_and_gyro_errors(default_scored):
    cal = default_scored[0].calibration()
    assert cal["track_width_scale"] == pytest.approx(1.02, abs=0.01)
    assert cal["wheel_radius_ratio"] == pytest.approx(1.003 / 0.997, abs=0.003)
    assert cal["distance_scale"] == pytest.approx(1.0, abs=0.005)
    # Turns in one direction only: the gyro's bias and scale are told apart only loosely.
    assert cal["gyro_bias"] == pytest.approx(math.radians(0.5), abs=math.radians(0.25))
    assert cal["gyro_scale"] == pytest.approx(1.01, abs=0.015)


def test_odometry_that_resets_its_heading_does_not_upset_the_gyro_filter(default_run):
    """An odometry whose heading a compass resets at 10 Hz (3 deg noise): not the wheels' steps."""
    r = default_run
    rng = np.random.default_rng(1)
    odom, x, y, th = [r.odom[0]], 0.0, 0.0, 0.0
    for k in range(1, 3000):
        a, b = r.odom[k - 1], r.odom[k]
        d = Pose2(a.x, a.y, a.theta).between(Pose2(b.x, b.y, b.theta))
        dth = d.theta
        if k % 10 == 0:
            dth = wrap_angle(r.truth[k].theta + math.radians(3.0) * rng.standard_normal() - th)
        x, y = x + d.x * math.cos(th + dth / 2), y + d.x * math.sin(th + dth / 2)
        th = wrap_angle(th + dth)
        odom.append(m.Odom(t=b.t, x=x, y=y, theta=th, v=b.v, omega=b.omega))
    ekf = Ekf(LocalizerConfig(), ROBOT)
    s = evaluate(ekf, odom, r.fixes, r.truth[:3000], r.imu[:3000])
    assert s.rmse < 0.01 and ekf.calibration()["track_width_scale"] == pytest.approx(1.02, abs=0.015)


def test_applying_fixes_at_capture_time_beats_ignoring_the_delay(default_run, default_scored):
    r = default_run
    as_now = evaluate(Ekf(LocalizerConfig(), ROBOT, delayed=False), r.odom, r.fixes, r.truth, r.imu)
    assert as_now.rmse > 3 * default_scored[1].rmse


@pytest.mark.parametrize(("samples", "depth"), [(1, 31), (2, 32), (3, 33)])
def test_a_late_fix_is_compared_with_the_past_and_replayed(samples, depth):
    ekf = tracking(3.0, history_samples=samples)
    rec = ekf.on_fix(fix(2.7, 0.81), 3.0)
    assert rec.accepted and rec.reason == "accepted"
    assert max(abs(v) for v in rec.innovation) < 0.01  # the robot was there at 2.7, not now
    # Re-integrated: every sample from the step that holds 2.70 to 3.00 (in steps of two, it begins at 2.69; of three, 2.68).
    assert rec.replay_depth == depth
    assert len(ekf.history) - 1 == pytest.approx(ekf.cfg.history / 0.01 / samples, abs=1)  # steps kept: 1.5 s of them
    p = ekf.get_pose()
    assert p.t == 3.0 and p.x == pytest.approx(0.9, abs=0.01)


@pytest.mark.parametrize("delayed", [True, False])
def test_steps_of_two_samples_track_as_a_step_per_sample_does(default_run, delayed):
    """The same 20 s of streams in steps of one and of two samples; without delay every fix is applied to the
    newest step in place, which must keep it when the next sample extends that step."""
    r, n = default_run, 2000
    fixes = [(t, f) for t, f in r.fixes if t <= r.odom[n - 1].t]
    scores = [
        evaluate(Ekf(LocalizerConfig(history_samples=k), ROBOT, delayed=delayed), r.odom[:n], fixes, r.truth[:n], r.imu[:n]) for k in (1, 2)
    ]
    assert scores[1].rmse == pytest.approx(scores[0].rmse, abs=0.001) and scores[1].max == pytest.approx(scores[0].max, abs=0.002)


def test_no_delay_mode_sees_the_motion_as_an_innovation():
    ekf = tracking(3.0, gate=1e3)
    ekf.delayed = False
    rec = ekf.on_fix(fix(2.7, 0.81), 3.0)
    assert rec.innovation[0] == pytest.approx(-0.09, abs=0.01) and rec.replay_depth == 0


def test_out_of_order_fixes_give_the_same_estimate():
    a, b = tracking(3.0), tracking(3.0)
    f1, f2 = fix(2.65, 0.8), fix(2.75, 0.83)
    a.on_fix(f1, 3.0)
    a.on_fix(f2, 3.0)
    b.on_fix(f2, 3.0)
    b.on_fix(f1, 3.0)
    pa, pb = a.get_pose(), b.get_pose()
    assert (pa.x, pa.y, pa.theta) == pytest.approx((pb.x, pb.y, pb.theta), abs=1e-9)


def test_fix_reasons_too_old_future_no_odom_and_before_set_pose():
    ekf = Ekf(LocalizerConfig(), ROBOT)
    assert ekf.on_fix(fix(0.0, 0.0), 0.3).reason == "no_odom_yet"
    ekf = tracking(3.0)
    assert ekf.on_fix(fix(1.0, 0.3), 3.0).reason == "too_old"  # history is 1.5 s
    assert ekf.on_fix(fix(3.2, 0.96), 3.0).reason == "future"
    assert ekf.on_fix(fix(3.03, 0.909), 3.0).accepted  # within the tolerance: taken as now
    ekf.set_pose(3.0, x=5.0)
    assert ekf.on_fix(fix(2.9, 0.87), 3.05).reason == "before_set_pose"


def test_starts_from_two_agreeing_fixes_never_from_a_lone_outlier():
    ekf = Ekf(LocalizerConfig(), ROBOT)
    straight(ekf, 0.0, 1.0)
    assert ekf.get_pose().cov[0] > 1.0  # odometry only: position unknown
    reasons = [ekf.on_fix(f, 1.0).reason for f in (fix(0.5, 0.65), fix(0.6, 0.18), fix(0.7, 0.21))]
    assert reasons == ["unconfirmed", "unconfirmed", "initialised"]
    p = ekf.get_pose()
    assert p.x == pytest.approx(0.3, abs=0.02) and p.cov[0] < 2 * 0.02**2


def test_the_fix_a_start_was_confirmed_by_is_used_too():
    ekf = Ekf(LocalizerConfig(), ROBOT)
    straight(ekf, 0.0, 1.0)
    reasons = [ekf.on_fix(f, 1.0).reason for f in (fix(0.6, 0.19), fix(0.7, 0.20))]  # 1 cm ahead, then 1 cm behind
    assert reasons == ["unconfirmed", "initialised"]
    p = ekf.get_pose()
    assert p.x == pytest.approx(0.3, abs=0.002)  # both, weighed alike: the second alone would put it 1 cm behind
    assert p.cov[0] < 0.7 * 0.02**2  # about half a fix's variance (the second alone: a fix's, and more)


def test_outliers_are_rejected_and_a_moved_robot_is_reacquired():
    ekf = tracking(3.0)
    rec = ekf.on_fix(fix(2.7, 0.81, 0.5), 3.0)
    assert not rec.accepted and rec.reason == "outlier" and rec.mahalanobis_d2 > 100
    reasons = []
    for k in range(31, 45):  # the robot was carried 1 m sideways: every fix now disagrees
        t = k / 10
        straight(ekf, t - 0.09, t)
        reasons.append(ekf.on_fix(fix(t - 0.3, 0.3 * (t - 0.3), 1.0), t).reason)
    # The fifth rejection in a row, confirmed by the fourth, re-acquires; then all agree.
    assert reasons[:4] == ["outlier"] * 3 + ["reacquired"]
    assert all(r == "accepted" for r in reasons[4:])
    assert ekf.get_pose().y == pytest.approx(1.0, abs=0.03)


@pytest.mark.parametrize("gap", [False, True])
def test_a_reacquisition_finds_a_slip_only_where_the_fixes_kept_coming(gap):
    """Fixes 0.5 m ahead of the odometry: the robot was pushed while the camera saw it (a slip: a move that
    stopped then is not moved again), or the odometry drifted while the camera had lost it for 5 s."""
    ekf = tracking(3.0)
    start = 8.1 if gap else 3.1
    straight(ekf, 3.01, start - 0.1)
    found, slipping = [], []
    for k in range(round(start * 10), round(start * 10) + 12):
        t = k / 10
        straight(ekf, t - 0.09, t)
        found.append(ekf.on_fix(fix(t - 0.3, 0.3 * (t - 0.3) + 0.5), t).reason)
        slipping.append(ekf.get_pose().slipping)
    assert "reacquired" in found
    assert any(slipping) != gap


def test_fixes_finer_than_a_tick_are_followed_through_coarse_encoders():
    """A camera to the millimetre, encoders of 13 mm a tick: the odometry's pose is off by its ticks' rounding at
    any time, which a fix's comparison allows for. Without it a fifth of the fixes were outliers, and the
    re-acquisitions that followed were taken for slipping wheels."""
    sc = msgspec.structs.replace(scenario("coarse"), vps_noise_xy=0.001, vps_noise_theta_deg=0.2)
    r = drive_square(sc, 8)
    ekf = Ekf(LocalizerConfig(), RobotConfig(ticks_per_rev=sc.ticks_per_rev))
    s = evaluate(ekf, r.odom, r.fixes, r.truth, r.imu)
    assert s.fixes_rejected <= 0.02 * (s.fixes_accepted + s.fixes_rejected) and s.rmse < 0.004
    assert ekf.slip == (math.inf, -math.inf)  # never found slipping


def pinned(accel=None, **cfg) -> list[float]:
    """The error [m] at each odom sample of a robot that drives into another at t = 1 s (x = 0.3 m) and is held
    there for 4 s while its wheels slip on: the odometry goes on at 0.3 m/s, the fixes (0.3 s late) see it stand.
    `accel`: with an IMU (as `straight`)."""
    ekf = tracking(1.0, accel=accel, **cfg)
    errors = []
    for k in range(101, 501):
        t = k / 100
        straight(ekf, t, t, accel=accel)
        if k % 10 == 5:
            ekf.on_fix(fix(t - 0.3, min(0.3 * (t - 0.3), 0.3)), t)
        errors.append(ekf.get_pose().x - 0.3)
    return errors


def felt(t: float) -> float:
    """[m/s^2] the pinned robot's accelerometer: its bias, and the stop (0.3 m/s lost over the step to 1.01 s)."""
    return 0.02 - (30.0 if round(t * 100) == 101 else 0.0)


def test_wheels_slipping_against_an_obstacle_are_found_and_the_fixes_followed():
    found, not_found = pinned(), pinned(slip_noise=0.0)
    # Found slipping once two fixes in a row moved less than half the odometry's travel over half a second (a
    # fix's latency later), the filter follows the fixes, off by what the odometry adds over a fix's
    # latency (0.09 m at 0.3 m/s). Trusting the wheels' travel, it runs off until the fixes it rejects
    # re-acquire the robot, again and again.
    assert max(found) < 0.21 and max(found[150:]) < 0.11
    assert max(not_found[150:]) > 0.25


def test_an_impact_the_accelerometer_feels_finds_the_wheels_slipping_at_once():
    ekf = tracking(1.03, accel=felt)  # the stop came over the step to 1.01 s
    assert ekf.impacts == 1 and ekf.get_pose().slipping
    # Found at the impact, not two late fixes later: the first fix after it is followed at once.
    felt_errors, fixes_errors = pinned(felt), pinned()
    assert max(felt_errors) < 0.13 and max(fixes_errors) > 0.18
    assert pinned(felt, impact_speed=0.0) == fixes_errors  # not read
    assert pinned(lambda t: 0.0) == fixes_errors  # an IMU without an accelerometer (both readings 0): not read


def test_a_free_drive_is_no_impact(default_scored):
    ekf = tracking(5.0, accel=lambda t: 0.02)  # the accelerometer's bias only: it keeps its speed
    assert ekf.impacts == 0 and not ekf.get_pose().slipping
    assert default_scored[0].impacts == 0  # the square: starts, stops and turns, the IMU's noise and bias


def test_encoders_too_coarse_to_tell_an_impact_leave_the_accelerometer_unread():
    assert Ekf(LocalizerConfig(), RobotConfig(ticks_per_rev=16)).impact is None
    assert Ekf(LocalizerConfig(), ROBOT).impact is not None


def test_set_pose_mid_drive_resets_and_tracking_continues():
    ekf = tracking(3.0)
    p = ekf.set_pose(3.0, x=2.0, y=-1.0, theta=0.0)
    assert (p.x, p.y, p.theta) == pytest.approx((2.0, -1.0, 0.0))
    assert len(ekf.history) == 1
    straight(ekf, 3.01, 3.5)
    assert ekf.get_pose().x == pytest.approx(2.15, abs=1e-6)
    # The camera still sees the robot where it is: the filter follows it back.
    reasons = []
    for k in range(36, 60):
        t = k / 10
        straight(ekf, t - 0.09, t)
        reasons.append(ekf.on_fix(fix(t - 0.3, 0.3 * (t - 0.3)), t).reason)
    assert "reacquired" in reasons and ekf.get_pose().x == pytest.approx(0.3 * 5.9, abs=0.03)


def test_set_heading_only_keeps_the_position():
    ekf = tracking(3.0)
    before = ekf.get_pose()
    p = ekf.set_pose(3.0, theta=0.5)
    assert (p.x, p.y, p.theta) == pytest.approx((before.x, before.y, 0.5))
    assert ekf.get_pose().cov[8] == pytest.approx(0.01**2)


def test_late_gyro_samples_fill_the_history(default_run):
    r = default_run
    n = 1500
    early, late = Ekf(LocalizerConfig(), ROBOT), Ekf(LocalizerConfig(), ROBOT)
    fixes = iter(r.fixes)
    pending = next(fixes)
    for i in range(n):
        while pending[0] <= r.odom[i].t:
            early.on_fix(pending[1], pending[0])
            late.on_fix(pending[1], pending[0])
            pending = next(fixes)
        early.on_imu(r.imu[i])
        early.on_odom(r.odom[i])
        late.on_odom(r.odom[i])
        late.on_imu(r.imu[i])  # after its odom sample
    pe, pl = early.get_pose(), late.get_pose()
    assert (pe.x, pe.y, pe.theta) == pytest.approx((pl.x, pl.y, pl.theta), abs=1e-3)


def test_correction_is_reported_once_on_the_next_pose():
    ekf = tracking(3.0)
    ekf.on_fix(fix(2.75, 0.85), 3.0)  # 2.5 cm ahead of where the filter has the robot
    straight(ekf, 3.01, 3.01)
    dx = ekf.get_pose().correction[0]
    assert 0.001 < dx < 0.03
    straight(ekf, 3.02, 3.02)
    assert ekf.get_pose().correction == (0.0, 0.0, 0.0)


def test_latency_is_measured_from_the_fixes():
    ekf = tracking(3.0)
    assert ekf.latency == pytest.approx(0.3, abs=1e-9)


@pytest.mark.parametrize(
    "cov",
    [
        (1e-4, 0.0, 0.0, 0.0, 1e-4, 0.0, 0.0, 0.0, 0.0),  # a heading the camera claims is perfect
        (1e-4, 5e-4, 0.0, 5e-4, 1e-4, 0.0, 0.0, 0.0, -1.0),  # not a covariance at all
    ],
)
def test_odd_fix_covariances_are_made_usable(cov):
    ekf = tracking(3.0)
    rec = ekf.on_fix(m.VpsPose(t=2.7, x=0.81, y=0.0, theta=0.0, cov=cov), 3.0)
    p = ekf.get_pose()
    assert rec.accepted and math.isfinite(rec.mahalanobis_d2) and p.cov[8] > 0.0


def test_a_fix_sent_twice_is_used_once():
    ekf = tracking(3.0)
    first = ekf.on_fix(fix(2.7, 0.81), 3.0)
    P = ekf.get_pose().cov
    again = ekf.on_fix(fix(2.7, 0.81), 3.01)
    assert first.accepted and not again.accepted and again.reason == "duplicate"
    assert ekf.get_pose().cov == P  # its weight counted once


def test_a_fix_after_the_odometry_restarted_is_used():
    ekf = tracking(3.0)
    x = ekf.get_pose().x
    assert ekf.on_odom(m.Odom(t=4.0, x=0.0, y=0.0, theta=0.0, v=0.0, omega=0.0)) == "jump"  # a new odom frame, 1 s on
    assert ekf.get_pose().x == pytest.approx(x) and ekf.get_pose().t == 4.0
    rec = ekf.on_fix(fix(3.7, x), 4.0)  # captured during the gap
    assert rec.accepted, rec
