"""The odometry state machine: ticks to poses, robustness, covariance and heading sources."""

import math

import numpy as np
import pytest

from zenav.common.config import Settings
from zenav.common.geometry import wrap_angle
from zenav.services.odometry import heading as hd
from zenav.services.odometry import odometry as od

ROBOT = Settings.load(None).robot  # nominal: 0.0673 m wheels, 0.1156 m track, 360 ticks/rev
R, L, TPR = ROBOT.wheel_radius, ROBOT.track_width, ROBOT.ticks_per_rev
DT = 0.01  # [s] 100 Hz


def params(source="encoders", integrator="arc", weights=(1.0, 1.0, 0.0), k=1e-4, robot=ROBOT, compass_gain=1.0, subtick=True):
    heading = hd.HeadingParams(
        source=source,
        weights=weights,
        gyro_var_rate=5e-4,
        accel_var_rate=1e-2,
        compass_var=0.05**2,
        compass_gain=compass_gain,
        still_time=0.5,
        still_rate=0.02,
        bias_time=5.0,
        accel_min_speed=0.05,
        imu_timeout=0.1,
        compass_timeout=0.5,
    )
    return od.make_params(robot, integrator, k, k, 3.0, heading, (2.0, 5.0, 0.3), subtick)


def ticks(angle, tpr=TPR, start=0):
    """Encoder count of a wheel turned by angle [rad], wrapped like the hardware."""
    return (math.floor(angle / (2.0 * math.pi) * tpr) + start + 2**31) % 2**32 - 2**31


def wheel_rates(v, omega):
    return (v - omega * L / 2.0) / R, (v + omega * L / 2.0) / R


def drive(p, segments, state=None, start=0, tpr=TPR, t0=0.0):
    """Feed encoder samples for segments of (duration [s], v, omega); return (state, odoms)."""
    s = state or od.OdometryState()
    t, al, ar, odoms = t0, 0.0, 0.0, []
    s, _, _ = od.update(s, p, ticks(al, tpr, start), ticks(ar, tpr, start), t)
    for duration, v, omega in segments:
        wl, wr = wheel_rates(v, omega)
        for _ in range(round(duration / DT)):
            t, al, ar = round(t + DT, 9), al + wl * DT, ar + wr * DT
            s, o, ev = od.update(s, p, ticks(al, tpr, start), ticks(ar, tpr, start), t)
            assert ev == od.OK and o is not None and o.t == t
            odoms.append(o)
    return s, odoms


def test_first_sample_only_sets_the_baseline():
    s, o, ev = od.update(od.OdometryState(), params(), 1000, -5000, 3.0)
    assert o is None and ev == od.BASELINE and (s.t, s.left, s.right, s.x) == (3.0, 1000, -5000, 0.0)
    s, o, ev = od.update(s, params(), 1000, -5000, 3.01)
    assert ev == od.OK and (o.x, o.y, o.theta, o.v, o.omega) == (0.0, 0.0, 0.0, 0.0, 0.0)


def test_straight_metre():
    _, odoms = drive(params(), [(5.0, 0.2, 0.0)])
    o = odoms[-1]
    tick = math.pi * ROBOT.wheel_diameter / TPR  # [m] travel of one tick
    assert o.x == pytest.approx(1.0, abs=tick) and o.y == 0.0 and o.theta == 0.0
    assert o.v == pytest.approx(0.2, abs=tick / DT) and o.frame == "odom"


@pytest.mark.parametrize("integrator", ["euler", "midpoint", "rk4", "arc"])
def test_quarter_circle_from_quantised_ticks(integrator):
    """0.2 m/s at 0.5 rad/s for pi seconds: a quarter of a circle of radius 0.4 m."""
    _, odoms = drive(params(integrator=integrator), [(math.pi, 0.2, 0.5)])
    o = odoms[-1]
    assert (o.x, o.y) == pytest.approx((0.4, 0.4), abs=0.005)  # quantisation: about a tick
    assert o.theta == pytest.approx(math.pi / 2, abs=0.01)
    assert o.omega == pytest.approx(0.5, abs=0.6)  # per-step rate, one tick of heading noise


def test_subtick_places_a_coarse_robot_between_its_ticks():
    """16 ticks/rev (13 mm a tick), straight at 0.1 m/s with the wheels' commands in the samples: the pose
    from the tick timing errs by a fraction of what whole ticks do."""
    coarse = ROBOT.__class__(ticks_per_rev=16)
    w = 0.1 / R  # [rad/s] each wheel
    errors = {}
    for sub in (False, True):
        p = params(robot=coarse, subtick=sub)
        s, _, _ = od.update(od.OdometryState(), p, 0, 0, 0.0)
        sq = []
        for i in range(1, 301):
            t = i * DT
            count = ticks(w * t, 16)
            s, o, _ = od.update(s, p, count, count, t, (w, w))
            if t > 1.0:
                sq.append((o.x - 0.1 * t) ** 2)
        errors[sub] = math.sqrt(sum(sq) / len(sq))
    tick = math.pi * ROBOT.wheel_diameter / 16
    assert errors[False] > 0.4 * tick  # uniform in a tick: 0.58 tick rms
    assert errors[True] < 0.1 * tick


def test_ticks_wrap_around_the_signed_32_bit_range():
    seg = [(2.0, 0.3, 0.4)]
    _, plain = drive(params(), seg)
    _, wrapped = drive(params(), seg, start=2**31 - 300)  # crosses 2^31 - 1 -> -2^31 early on
    assert [(o.x, o.y, o.theta) for o in wrapped] == [(o.x, o.y, o.theta) for o in plain]
    assert od.tick_delta(-(2**31), 2**31 - 1) == 1 and od.tick_delta(2**31 - 1, -(2**31)) == -1


def test_duplicate_old_and_zero_dt_samples_are_dropped():
    p = params()
    s, _ = drive(p, [(1.0, 0.2, 0.0)])
    for t in (s.t, s.t - 0.5):  # same t, older t
        s2, o, ev = od.update(s, p, s.left + 3, s.right + 3, t)
        assert (s2, o, ev) == (s, None, od.STALE)


def test_absurd_jump_is_an_encoder_reset():
    p = params()
    s, _ = drive(p, [(1.0, 0.2, 0.0)])
    x = s.x
    # 10 rad/s * 3 over 10 ms is 0.3 rad = 17 ticks: 5000 ticks is impossible
    s, o, ev = od.update(s, p, 5000, 5000, s.t + DT)
    assert o is None and ev == od.RESET and (s.left, s.right, s.x) == (5000, 5000, x)
    s, o, ev = od.update(s, p, 5003, 5003, s.t + DT)  # continues from the new baseline
    assert ev == od.OK and o.x == pytest.approx(x + 3 * math.pi * ROBOT.wheel_diameter / TPR)


def test_one_coarse_tick_in_a_short_step_is_not_a_reset():
    """16 ticks/rev: one tick in 10 ms looks like 39 rad/s, but it is quantisation."""
    coarse = ROBOT.__class__(ticks_per_rev=16)
    s, _, _ = od.update(od.OdometryState(), params(robot=coarse), 0, 0, 0.0)
    s, o, ev = od.update(s, params(robot=coarse), 1, 1, DT)
    assert ev == od.OK
    s, o, ev = od.update(s, params(robot=coarse), 4, 1, 2 * DT)
    assert ev == od.RESET


def test_covariance_grows_with_travel_and_stays_symmetric():
    p = params()
    s, odoms = drive(p, [(1.0, 0.0, 0.0), (3.0, 0.2, 0.3)])
    covs = [np.array(o.cov).reshape(3, 3) for o in odoms]
    assert np.all(covs[99] == 0.0)  # standing still adds nothing
    for c in covs[100::50]:
        assert np.allclose(c, c.T) and np.all(np.linalg.eigvalsh(c) > -1e-15)
    traces = [np.trace(c) for c in covs]
    assert all(b >= a for a, b in zip(traces, traces[1:]))
    # heading variance of the straight wheels model: 2 k |travel| / L^2 per wheel pair
    _, straight = drive(p, [(5.0, 0.2, 0.0)])
    assert straight[-1].cov[8] == pytest.approx(2 * 1e-4 * 1.0 / L**2, rel=0.02)
    _, exact = drive(params(k=0.0), [(2.0, 0.2, 0.3)])
    assert exact[-1].cov == (0.0,) * 9


# ---------------------------------------------------------------- heading sources
def feed(p, segments, gyro=lambda t, omega: omega, compass=None, imu_first=True, accel_y=lambda v, omega: v * omega):
    """Encoders plus IMU (and optionally compass at 10 Hz) at 100 Hz; returns (state, odoms, events)."""
    s = od.OdometryState()
    t, al, ar, odoms, events = 0.0, 0.0, 0.0, [], []
    s, _, _ = od.update(s, p, 0, 0, 0.0)
    truth = 0.0
    for duration, v, omega in segments:
        wl, wr = wheel_rates(v, omega)
        for _ in range(round(duration / DT)):
            t, al, ar, truth = round(t + DT, 9), al + wl * DT, ar + wr * DT, truth + omega * DT
            if imu_first:
                s, _ = od.on_imu(s, p, t, gyro(t, omega), accel_y(v, omega))
            if compass is not None and round(t / DT) % 10 == 0:
                s, _ = od.on_compass(s, t, compass(t, truth))
            s, o, ev = od.update(s, p, ticks(al), ticks(ar), t)
            if not imu_first:
                s, _ = od.on_imu(s, p, t, gyro(t, omega), accel_y(v, omega))
            odoms.append(o)
            events.append(ev)
    return s, odoms, events


def test_gyro_learns_its_bias_while_still_and_integrates_turns():
    bias = math.radians(0.5)
    segs = [(2.0, 0.0, 0.0), (math.pi, 0.0, 0.5), (1.0, 0.0, 0.0)]  # stand, turn 90 deg in place, stand
    s, odoms, _ = feed(params("gyro"), segs, gyro=lambda t, omega: omega + bias)
    assert s.imu.bias == pytest.approx(bias, rel=1e-6)
    assert odoms[-1].theta == pytest.approx(0.5 * 3.14, abs=1e-9)  # 314 samples at 0.5 rad/s
    assert odoms[-1].cov[8] == pytest.approx(5e-4 * 6.0, rel=0.05)  # gyro variance rate over 6 s


def test_gyro_heading_does_not_depend_on_arrival_order():
    """IMU samples after the encoder sample of the same t: extrapolated, then made up next step."""
    segs = [(1.0, 0.0, 0.0), (2.0, 0.2, 0.7), (1.0, 0.2, -0.4), (0.1, 0.0, 0.0)]
    wobble = lambda t, omega: omega * (1.0 + 0.2 * math.sin(7 * t))  # noqa: E731 - a rate the encoders do not see
    _, first, _ = feed(params("gyro"), segs, gyro=wobble, imu_first=True)
    _, late, _ = feed(params("gyro"), segs, gyro=wobble, imu_first=False)
    # at most one step of extrapolation with the old rate: the largest rate jump (1.3 rad/s) x dt
    assert max(abs(a.theta - b.theta) for a, b in zip(first, late)) < 1.3 * DT
    assert late[-1].theta == pytest.approx(first[-1].theta, abs=1e-12)  # nothing lost


def test_gyro_missing_falls_back_to_encoders():
    p = params("gyro", subtick=False)  # whole ticks: the encoders' turn is two ticks' difference
    s, odoms, events = feed(p, [(1.0, 0.2, 0.5)])
    assert events[-1] == od.OK
    s, o, ev = od.update(s, p, s.left + 1, s.right + 3, s.t + 0.2)  # IMU silent for 0.2 s
    tick = math.pi * ROBOT.wheel_diameter / TPR  # [m]
    assert ev == od.FALLBACK and o.theta == pytest.approx(odoms[-1].theta + 2 * tick / L)  # the encoders' turn


def test_compass_is_absolute_with_the_odom_offset_fixed_at_start():
    """The robot faces 1.0 rad in the map; the encoders overestimate turns by 20 %."""
    p = params("compass")
    segs = [(1.0, 0.0, 0.0), (math.pi, 0.0, 0.5), (2.0, 0.2, 0.0)]
    _, enc_only, _ = feed(params(), segs)
    s, odoms, events = feed(p, segs, compass=lambda t, truth: wrap_angle(1.0 + truth / 1.2))
    assert s.compass.offset == pytest.approx(1.0)
    assert odoms[-1].theta == pytest.approx(math.pi / 2 / 1.2, abs=1e-3)  # the compass heading, odom frame
    assert enc_only[-1].theta == pytest.approx(math.pi / 2, abs=0.01)
    assert odoms[-1].cov[8] == pytest.approx(0.05**2, rel=0.05)  # compass variance, not growing
    assert set(events) == {od.OK}


def test_compass_gain_keeps_odom_continuous_and_still_corrects_the_heading():
    """A compass with +-5 deg noise pulls the heading a tenth of the way: no jumps, no drift."""
    segs = [(1.0, 0.0, 0.0), (math.pi, 0.0, 0.5), (4.0, 0.2, 0.0)]
    noise = iter([math.radians(5.0) * (-1) ** i for i in range(10_000)])
    s, odoms, _ = feed(params("compass", compass_gain=0.1), segs, compass=lambda t, truth: wrap_angle(1.0 + truth / 1.2 + next(noise)))
    steps = [abs(wrap_angle(b.theta - a.theta)) for a, b in zip(odoms, odoms[1:])]
    assert max(steps) < math.radians(2.0)  # a full-gain compass would jump by up to 10 deg
    assert odoms[-1].theta == pytest.approx(math.pi / 2 / 1.2, abs=math.radians(1.5))  # encoder error corrected


def test_compass_offset_is_the_mean_of_the_samples_before_the_robot_moves():
    p = params("compass")
    noise = iter([0.05, -0.03, 0.01, -0.02, 0.04] + [0.0] * 100)
    s, odoms, _ = feed(p, [(0.5, 0.0, 0.0), (0.3, 0.2, 0.0)], compass=lambda t, truth: 1.0 + truth + next(noise))
    assert s.compass.offset == pytest.approx(1.0 + 0.01, abs=1e-12) and s.compass.samples == 5
    assert all(o.theta == 0.0 for o in odoms[:50])  # at rest at the start: the odom x axis
    assert odoms[-1].theta == pytest.approx(-0.01, abs=1e-12)  # noise-free samples once moving


def test_compass_silent_is_a_fallback():
    p = params("compass")
    s, _, _ = feed(p, [(1.0, 0.0, 0.0)], compass=lambda t, truth: 0.0)
    s, o, ev = od.update(s, p, s.left, s.right, s.t + 0.6)
    assert ev == od.FALLBACK


def test_stale_imu_and_compass_samples_are_dropped():
    p = params("gyro")
    s, _ = od.on_imu(od.OdometryState(), p, 1.0, 0.1, 0.0)
    assert od.on_imu(s, p, 1.0, 0.2, 0.0) == (s, od.STALE)
    s, _ = od.on_compass(s, 1.0, 0.3)
    assert od.on_compass(s, 0.9, 0.2) == (s, od.STALE)


def test_blend_is_the_weighted_average_of_heading_changes():
    """Gyro reads 1.5 x the turn: weights 1:1 put the heading halfway, 1:3 three quarters."""
    segs = [(1.0, 0.0, 0.0), (math.pi, 0.0, 0.5)]
    for weights, share in (((1.0, 1.0, 0.0), 0.5), ((1.0, 3.0, 0.0), 0.75), ((0.0, 1.0, 0.0), 1.0)):
        _, odoms, _ = feed(params("blend", weights=weights), segs, gyro=lambda t, omega: 1.5 * omega)
        assert odoms[-1].theta == pytest.approx(math.pi / 2 * (1 + 0.5 * share), abs=0.01), weights


def test_blend_uses_the_centripetal_rate_of_the_accelerometer():
    """Accelerometer only: omega = a_y / v; here it reads as if the turn were twice as fast."""
    segs = [(1.0, 0.0, 0.0), (2.0, 0.2, 0.5)]
    _, odoms, _ = feed(params("blend", weights=(0.0, 0.0, 1.0)), segs, accel_y=lambda v, omega: 2.0 * v * omega)
    assert odoms[-1].theta == pytest.approx(2.0 * 1.0, abs=0.03)
