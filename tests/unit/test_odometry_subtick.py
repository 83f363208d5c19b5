"""A wheel's position within its encoder tick from the tick timing."""

import math

import pytest

from zenav.services.odometry import subtick as st

DT = 0.01  # [s] 100 Hz
LAG = 0.05  # [s] the motors' time constant ([odometry] motor_lag's default)


def follow(positions, dt=DT, cmds=None):
    """Feed the floor-rounded counts of a wheel at `positions` [ticks], one per sample from t = 0, commanded
    `cmds` [ticks/s] (default: the speed it turns at); return (true position, estimate, count) per sample after the first."""
    w, count, out = st.Wheel(), math.floor(positions[0]), []
    for i, pos in enumerate(positions[1:], 1):
        new = math.floor(pos)
        cmd = (pos - positions[i - 1]) / dt if cmds is None else cmds[i - 1]
        w = st.step(w, new - count, i * dt, dt, cmd, LAG)
        count = new
        out.append((pos, count + w.frac, count))
    return out


@pytest.mark.parametrize("speed", [3.7, 13.0, 24.5, -13.0])  # [ticks/s]: a 16-tick wheel up to 10 rad/s, and back
def test_constant_speed_is_followed_within_a_fraction_of_a_tick(speed):
    samples = follow([0.3 + speed * i * DT for i in range(300)])
    late = samples[len(samples) // 3 :]  # after the first edges have given the speed
    # the edge times are known to half a sample: at 0.25 tick a sample the estimate errs by up to 0.3 tick
    assert max(abs(est - pos) for pos, est, _ in late) < 0.3  # whole ticks: up to 1
    rms = math.sqrt(sum((est - pos) ** 2 for pos, est, _ in late) / len(late))
    assert rms < 0.1  # whole ticks: 0.58


def test_every_estimate_lies_in_the_tick_the_count_says():
    speeds = [10.0] * 50 + [0.0] * 30 + [-7.0] * 60 + [20.0] * 40  # [ticks/s]
    pos, positions = 0.0, [0.0]
    for v in speeds:
        pos += v * DT
        positions.append(pos)
    for _, est, count in follow(positions):
        assert count <= est <= count + 1


def test_a_stopped_wheel_coasts_inside_its_tick_and_comes_to_rest():
    """Steady at 10 ticks/s, then commanded to stop at 0.3 of a tick: the estimate coasts on inside the tick,
    never back, and comes to rest short of the tick's end."""
    positions = [10.0 * i * DT for i in range(101)] + [10.3] * 100  # an edge at 10.0, then 0.3 tick on
    samples = follow(positions)
    stopped = [est for _, est, count in samples[100:] if count == 10]
    assert len(stopped) == 100 and all(10.0 <= est < 11.0 for est in stopped)
    assert stopped == sorted(stopped)  # on, never back
    assert stopped[-1] - stopped[-50] < 1e-3  # at rest: the coast has died out


def test_a_stalled_wheel_still_commanded_waits_at_its_ticks_end():
    """Commanded on at 10 ticks/s but held at 10.3: the estimate runs to the tick's end and no further."""
    positions = [10.0 * i * DT for i in range(101)] + [10.3] * 100
    samples = follow(positions, cmds=[10.0] * 200)
    assert all(count == 10 and est <= 11.0 for _, est, count in samples[100:])
    assert samples[-1][1] == 11.0


def test_motor_follows_its_command_with_its_lag():
    travel, rate = st.motor(10.0, LAG, 0.0, LAG)  # told to stop: one lag later
    assert rate == pytest.approx(10.0 / math.e) and travel == pytest.approx(10.0 * LAG * (1.0 - 1.0 / math.e))
    assert st.motor(0.0, 10.0, 4.0, LAG)[1] == pytest.approx(4.0)  # long after: at the command
    assert st.motor(10.0, 0.02, 4.0, 0.0) == (4.0 * 0.02, 4.0)  # no lag: the command at once


def test_a_wheel_commanded_slower_or_not_at_all_runs_on_slower_or_coasts():
    """After edges at 10 ticks/s: commanded 4 ticks/s it runs on slower than 10, commanded 0 less far, back
    less far still; never back through its edge."""
    w = st.step(st.Wheel(), 1, 0.1, 0.1, 10.0, LAG)  # the first edge (taken at 0.05 s): no edges' speed yet
    assert w.speed == 0.0 and 0.0 < w.frac < 0.5  # spun up from rest by the model: under 10 ticks/s * 0.05 s
    w = st.step(w, 1, 0.2, 0.1, 10.0, LAG)  # the next at 0.15 s: 10 ticks/s
    assert w.speed == pytest.approx(10.0) and w.rate == pytest.approx(10.0, rel=0.2)
    on = [st.step(w, 0, 0.21, 0.01, c, LAG).frac - w.frac for c in (10.0, 4.0, 0.0, -4.0)]
    assert on == sorted(on, reverse=True) and on[-1] >= 0.0
    assert on[1] < 10.0 * 0.01


def test_a_reversal_within_a_tick_jumps_back_to_the_new_counts_edge_or_below():
    """Forward into tick 5 (edge at 5.0), back out through 5.0: the count 4 says the wheel is below 5.0."""
    fwd = [4.0 + 0.1 * i for i in range(18)]  # 4.0 .. 5.7
    back = [5.7 - 0.1 * i for i in range(1, 20)]  # 5.6 .. 3.8
    samples = follow(fwd + back)
    turned = next(i for i, (_, _, c) in enumerate(samples) if c == 4 and i > 10)
    pos, est, _ = samples[turned]
    assert pos - 0.05 <= est <= 5.0  # at or below the edge the count fell through (whole ticks: 4.0)
    for _, est, count in samples[turned:]:
        assert count <= est <= count + 1
    # after the reversal the speed comes from the next edge in the new direction, not the old one
    pos, est, _ = samples[-1]
    assert abs(est - pos) < 0.3


def test_the_edges_speed_corrects_a_model_that_is_wrong():
    """Commanded 15 ticks/s but turning at 10 (a weak motor): the edges scale the model's speed to the ticks made."""
    samples = follow([0.3 + 10.0 * i * DT for i in range(300)], cmds=[15.0] * 299)
    late = samples[len(samples) // 3 :]
    assert max(abs(est - pos) for pos, est, _ in late) < 0.3
    rms = math.sqrt(sum((est - pos) ** 2 for pos, est, _ in late) / len(late))
    assert rms < 0.2  # whole ticks: 0.58


def test_before_the_first_edge_the_estimate_holds_at_the_baseline():
    w = st.Wheel()
    for i in range(1, 6):
        w = st.step(w, 0, i * DT, DT, 10.0, LAG)
    assert w.frac == 0.0 and w.rate > 0.0  # the model spins up; the position waits for an edge


def test_several_ticks_in_one_sample():
    """A 360-tick wheel at 10 rad/s: about 5.7 ticks per sample; the estimate stays within its tick and near the truth."""
    speed = 10.0 * 360 / (2.0 * math.pi)  # [ticks/s]
    samples = follow([speed * i * DT for i in range(200)])
    assert all(count <= est <= count + 1 for _, est, count in samples)
    late = samples[10:]
    mean = sum(est - pos for pos, est, _ in late) / len(late)
    assert abs(mean) < 0.15  # whole ticks: -0.5 on average
    assert max(abs(est - pos) for pos, est, _ in late) < 0.6


def test_travel_is_the_counts_plus_the_fractions():
    a = st.Wheel(frac=0.25)
    b = st.Wheel(frac=0.75)
    assert st.travel(a, b, 3) == 3.5 and st.travel(b, a, -3) == -3.5
