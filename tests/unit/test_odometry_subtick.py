"""A wheel's position within its encoder tick from the tick timing."""

import math

import pytest

from zenav.services.odometry import subtick as st

DT = 0.01  # [s] 100 Hz


def follow(positions, dt=DT, cmds=None):
    """Feed the floor-rounded counts of a wheel at `positions` [ticks], one per sample from t = 0, commanded
    `cmds` [ticks/s] (default: the speed it turns at); return (true position, estimate, count) per sample after the first."""
    w, count, out = st.Wheel(), math.floor(positions[0]), []
    for i, pos in enumerate(positions[1:], 1):
        new = math.floor(pos)
        cmd = (pos - positions[i - 1]) / dt if cmds is None else cmds[i - 1]
        w = st.step(w, new - count, i * dt, dt, cmd)
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


def test_a_stopped_wheel_waits_at_its_tick_and_stays():
    """Steady at 10 ticks/s, then stopped at 0.3 of a tick: the estimate goes no further than the tick's end."""
    positions = [10.0 * i * DT for i in range(101)] + [10.3] * 100  # an edge at 10.0, then 0.3 tick on
    samples = follow(positions)
    stopped = samples[110:]
    assert all(count == 10 and 10.0 <= est <= 11.0 for _, est, count in stopped)
    assert len({est for _, est, _ in stopped}) == 1  # still: the estimate no longer moves


def test_a_stalled_wheel_still_commanded_waits_at_its_ticks_end():
    """Commanded on at 10 ticks/s but held at 10.3: the estimate runs to the tick's end and no further."""
    positions = [10.0 * i * DT for i in range(101)] + [10.3] * 100
    samples = follow(positions, cmds=[10.0] * 200)
    assert all(count == 10 and est <= 11.0 for _, est, count in samples[100:])
    assert samples[-1][1] == 11.0


def test_a_wheel_commanded_slower_or_not_at_all_runs_on_slower_or_not():
    """After edges at 10 ticks/s: commanded 4 ticks/s it runs on at 4, commanded 0 or back it holds."""
    w = st.step(st.Wheel(), 1, 0.1, 0.1, 10.0)  # the first edge (taken at 0.05 s): no speed yet
    assert (w.speed, w.frac) == (0.0, 0.0)
    w = st.step(w, 1, 0.2, 0.1, 10.0)  # the next at 0.15 s: 10 ticks/s
    assert w.speed == pytest.approx(10.0) and w.frac == pytest.approx(0.5)  # 0.05 s after the edge
    assert st.step(w, 0, 0.21, 0.01, 4.0).frac == pytest.approx(0.54)
    assert st.step(w, 0, 0.21, 0.01, 0.0) == w
    assert st.step(w, 0, 0.21, 0.01, -4.0) == w


def test_a_reversal_within_a_tick_jumps_back_only_to_the_new_counts_edge():
    """Forward into tick 5 (edge at 5.0), back out through 5.0: the count 4 says the wheel is below 5.0."""
    fwd = [4.0 + 0.1 * i for i in range(18)]  # 4.0 .. 5.7
    back = [5.7 - 0.1 * i for i in range(1, 20)]  # 5.6 .. 3.8
    samples = follow(fwd + back)
    turned = next(i for i, (_, _, c) in enumerate(samples) if c == 4 and i > 10)
    _, est, _ = samples[turned]
    assert est == pytest.approx(5.0)  # the edge the count fell through, not the tick's bottom (whole ticks: 4.0)
    for _, est, count in samples[turned:]:
        assert count <= est <= count + 1
    # after the reversal the speed comes from the next edge in the new direction, not the old one
    pos, est, _ = samples[-1]
    assert abs(est - pos) < 0.3


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
