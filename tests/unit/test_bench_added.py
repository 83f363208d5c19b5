"""What the services add: the stack's end to end less its relay arm's, pooled over runs, with a bootstrap interval;
and the relay arm's relays' outputs."""

from __future__ import annotations

import numpy as np
import pytest

from zenav.bench import added, arm
from zenav.common import codec
from zenav.common import messages as m


def runs(shift: float, seed: int) -> list[list[float]]:
    rng = np.random.default_rng(seed)
    return [(1.0 + shift + rng.exponential(0.2, 400)).tolist() for _ in range(3)]


def test_the_added_latency_is_the_difference_and_its_interval_holds_it():
    got = added.measure(runs(0.3, 1), runs(0.0, 2))
    assert got.runs == 3 and got.n == (1200, 1200)
    assert got.added[0] == pytest.approx(got.stack[0] - got.arm[0])
    assert got.low[0] < 0.3 < got.high[0]
    assert got.low[0] < got.added[0] < got.high[0] and got.low[1] < got.added[1] < got.high[1]
    assert "services' added latency, clients: p50 0.3" in got.line("clients")


def test_the_same_stack_on_both_arms_adds_nothing_within_the_interval():
    got = added.measure(runs(0.0, 3), runs(0.0, 4))
    assert got.low[0] < 0.0 < got.high[0]


def test_runs_must_pair_up_and_hold_samples():
    with pytest.raises(ValueError):
        added.measure(runs(0.0, 1), runs(0.0, 2)[:2])
    with pytest.raises(ValueError):
        added.measure([[1.0], []], [[1.0], [1.0]])


def test_a_relay_publishes_its_service_output_type_stamped_with_the_input_t():
    sample = codec.encode(m.Encoders(t=1.25, left=10, right=12))
    ((topic, data),) = arm.outputs("odometry", sample, "pose")
    assert topic == "odom" and codec.decode(data, m.Odom).t == 1.25
    chained = arm.outputs(arm.COMPOSED, sample, "pose")
    assert [t for t, _ in chained] == ["odom", "pose", "cmd_vel", "motors/wheels"]
    assert codec.decode(chained[-1][1], m.Wheels).t == 1.25
    with pytest.raises(codec.BadInput):
        arm.outputs("navigator", sample, "pose")  # an encoder sample is no pose


def test_with_control_on_odom_the_navigator_relay_reads_odom_and_the_localizer_is_off_the_chain():
    hops = arm.hops("odom")
    assert list(hops) == ["odometry", "navigator", "motor", "localizer"]  # the chain's order, then the one off it
    assert hops["navigator"].input == "odom" and hops["localizer"].input == "odom"
    ((topic, data),) = arm.outputs("navigator", codec.encode(m.Odom(t=2.5, x=0.0, y=0.0, theta=0.0, v=0.0, omega=0.0)), "odom")
    assert topic == "cmd_vel" and codec.decode(data, m.CmdVel).t == 2.5
    chained = arm.outputs(arm.COMPOSED, codec.encode(m.Encoders(t=1.25, left=10, right=12)), "odom")
    assert [t for t, _ in chained] == ["odom", "cmd_vel", "motors/wheels", "pose"]
