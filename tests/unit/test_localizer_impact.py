"""The accelerometer against the odometry: impacts found, free driving not."""

import math
import random

import pytest

from zenav.services.localizer.impact import MAX_WINDOW, WINDOW, Impact, window

TICK = 2.0 * math.pi * 0.0336 / 360  # [m] the default robot's encoder tick
DT = 0.01  # [s] 100 Hz


def drive(speed, accel, seconds=3.0, noise=0.05, bias=0.02, seed=1, tick=TICK):
    """Run a detector on a robot whose wheels turn at speed(t) [m/s] and whose body feels accel(t, v, v_before) [m/s^2]
    (plus noise and bias); the encoders count whole ticks. Returns the times it said the speeds disagree."""
    rng = random.Random(seed)
    d = Impact(0.05, 0.25, window(0.05, tick), 1.5, 0.1)
    travel, counted, before, found = 0.0, 0, 0.0, []
    for k in range(1, round(seconds / DT)):
        t = k * DT
        v = speed(t)
        travel += v * DT
        d.on_imu(t, accel(t, v, before) + bias + rng.gauss(0.0, noise), 0.1, 0.0)
        before = v
        ticks = math.floor(travel / tick)
        if d.on_odom(t - DT, t, (ticks - counted) * tick):
            found.append(t)
        counted = ticks
    return found


def gripping(t, v, before):
    """The body feels what the wheels do."""
    return (v - before) / DT


def ramp(t):
    """Off at 3 m/s^2 (the motor's limit) to 0.17 m/s."""
    return min(0.17, 3.0 * t)


def test_starting_cruising_and_stopping_hard_is_no_impact():
    assert drive(ramp, gripping) == []
    assert drive(lambda t: 0.3 * math.sin(2.0 * math.pi * t), gripping, seconds=10.0, noise=0.1, bias=0.05) == []


def test_a_wall_that_stops_the_body_while_the_wheels_turn_on_is_found_within_three_samples():
    def wall(t, v, before):  # 0.17 m/s lost in the step to 1.5 s, then held
        return gripping(t, v, before) if t < 1.495 else (-0.17 / DT if t < 1.505 else 0.0)

    found = drive(ramp, wall)
    assert found and 1.5 <= found[0] <= 1.53


def test_wheels_that_spin_up_while_the_body_is_held_are_found():
    found = drive(ramp, lambda t, v, before: 0.0)
    assert found and found[0] <= 0.1


def test_a_slower_disagreement_than_impact_speed_is_not_found():
    def wall(t, v, before):  # 0.03 m/s lost
        return gripping(t, v, before) if t < 1.495 else (-0.03 / DT if t < 1.505 else 0.0)

    assert drive(lambda t: min(0.03, 3.0 * t), wall) == []


def test_an_imu_without_an_accelerometer_is_not_read():
    d = Impact(0.05, 0.25, WINDOW, 1.5, 0.1)
    for k in range(1, 100):
        d.on_imu(k * DT, 0.0, 0.0, 0.0)
        assert not d.on_odom((k - 1) * DT, k * DT, 0.003 * min(k, 20))  # the wheels speed up: nothing to compare with
    assert d.accel.newest is None


@pytest.mark.parametrize("ticks, expected", [(360, WINDOW + 0.0069), (90, None), (16, None), (4096, WINDOW)])
def test_the_window_grows_with_the_tick_and_coarse_encoders_leave_it_unread(ticks, expected):
    w = window(0.05, 2.0 * math.pi * 0.0336 / ticks)
    assert w == (None if expected is None else pytest.approx(expected, abs=1e-3))
    assert w is None or w <= MAX_WINDOW


@pytest.mark.parametrize("at", [(0.1, 0.0), (0.0, 0.05), (-0.08, -0.04)])
def test_an_imu_off_the_axle_feels_a_turn_in_place_which_is_no_impact_once_its_place_is_known(at):
    """A turn in place, its rate up to 3 rad/s in 0.3 s and held: the IMU at (x, y) reads -rate^2 x - spin y forward."""

    def turning(impact):
        found, rate = [], 0.0
        for k in range(1, 150):
            t = k * DT
            spin = 10.0 if t <= 0.3 else 0.0
            rate += spin * DT
            impact.on_imu(t, -rate * rate * at[0] - spin * at[1] + 0.02, 0.1, rate)
            if impact.on_odom(t - DT, t, 0.0):  # the wheels turn opposite ways: no forward travel
                found.append(t)
        return found

    assert turning(Impact(0.05, 0.25, WINDOW, 1.5, 0.1))  # where it is not known, the turn looks like a push
    assert turning(Impact(0.05, 0.25, WINDOW, 1.5, 0.1, at)) == []
