"""The latency arithmetic of the bench: stages add up to end to end, and percentiles."""

from __future__ import annotations

import math

import numpy as np
import pytest

from zenav.bench.latency import AROUND_FIX, END_TO_END, SPLIT, ChainRecorder, Stats, chain, near_fix, present, stages
from zenav.common import codec
from zenav.common import messages as m


class FakeClient:
    """Collects r1's subscriptions so the test can deliver messages by hand (encoded, as the bus does)."""

    def __init__(self) -> None:
        self.subs: dict[str, object] = {}
        self.callbacks = self  # callbacks[suffix](msg)

    def subscribe(self, key, callback) -> None:
        self.subs[key.removeprefix("zenav/r1/")] = callback

    def __getitem__(self, suffix):
        return lambda msg: self.subs[suffix](f"zenav/r1/{suffix}", codec.encode(msg))


def stamp(t: float, wall: float) -> m.Truth:
    """The sim's truth of step t, stamped with its wall clock."""
    return m.Truth(t=t, x=0.0, y=0.0, theta=0.0, v=0.0, omega=0.0, wall=wall)


@pytest.mark.parametrize("control_on", ["odom", "pose"])
def test_stages_split_end_to_end_exactly(monkeypatch, control_on):
    client = FakeClient()
    rec = ChainRecorder(client, "r1", control_on)
    wall = [1000.0]
    monkeypatch.setattr("zenav.bench.latency.time.time", lambda: wall[0])
    steps = {"sensors/encoders": 0.001, "odom": 0.002, "pose": 0.0005, "cmd_vel": 0.0007, "motors/wheels": 0.0004}  # [s]
    topics = chain(control_on)
    for t in (0.01, 0.02, 0.03):
        client.callbacks["sim/truth"](stamp(t, wall[0]))
        for topic in topics:
            wall[0] += steps[topic]
            client.callbacks[topic](m.Wheels(t=t, left=0.0, right=0.0))
        wall[0] += 0.1
    # t = 0.04 never reaches the wheels: left out; a repeated wheels t keeps the first arrival
    client.callbacks["sim/truth"](stamp(0.04, wall[0]))
    client.callbacks["sensors/encoders"](m.Encoders(t=0.04, left=0, right=0))
    wall[0] += 5.0
    client.callbacks["motors/wheels"](m.Wheels(t=0.03, left=0.0, right=0.0))
    out = rec.stages()
    split = [s for s in SPLIT if s in stages(control_on) or s == END_TO_END]
    assert set(out) == {*stages(control_on), END_TO_END, *(f"{s}, {g}" for s in split for g in AROUND_FIX)}
    assert present(out) == stages(control_on)
    assert len(out[END_TO_END]) == 3
    for stage, topic in zip(stages(control_on), topics):
        assert out[stage] == pytest.approx([steps[topic] * 1e3] * 3)
    assert out[END_TO_END] == pytest.approx([sum(steps[topic] for topic in topics) * 1e3] * 3)


def test_with_control_on_odom_the_chain_leaves_the_localizer_out():
    assert chain("odom") == ("sensors/encoders", "odom", "cmd_vel", "motors/wheels")
    assert stages("odom") == ("delivery", "odometry", "navigator", "motor")
    assert chain("pose") == ("sensors/encoders", "odom", "pose", "cmd_vel", "motors/wheels")


def test_bad_input_is_not_stamped():
    client = FakeClient()
    rec = ChainRecorder(client, "r1", "odom")
    client.subs["sim/truth"]("zenav/r1/sim/truth", b"\xc1")
    client.subs["motors/wheels"]("zenav/r1/motors/wheels", b"\xc1")
    assert rec.stamp == {} and rec.arrival["motors/wheels"] == {} and rec.stages()[END_TO_END] == []


def test_stats_percentiles_and_empty():
    st = Stats.of([float(i) for i in range(1, 101)])
    assert (st.n, st.max) == (100, 100.0)
    assert st.p50 == pytest.approx(50.5) and st.p99 == pytest.approx(99.01)
    empty = Stats.of([])
    assert empty.n == 0 and math.isnan(empty.p50)


def test_the_samples_just_after_a_fix_are_split_from_the_others(monkeypatch):
    client = FakeClient()
    rec = ChainRecorder(client, "r1", "pose")  # the localizer on the chain
    wall = [1000.0]
    monkeypatch.setattr("zenav.bench.latency.time.time", lambda: wall[0])
    fix = m.VpsPose(t=0.0, x=0.0, y=0.0, theta=0.0)
    for i in range(5):  # a fix 1.5 ms before sample 1's odom arrives, 4.5 ms before sample 3's; sample 1's pose 1 ms late
        t = 0.01 * (i + 1)
        client.callbacks["sim/truth"](stamp(t, wall[0]))
        for topic in chain("pose"):
            if topic == "odom" and i in (1, 3):
                client.callbacks["vps/pose"](fix)
                wall[0] += 0.001 if i == 1 else 0.004
            wall[0] += 0.003 if (topic, i) == ("pose", 1) else 0.002 if topic == "pose" else 0.0005
            client.callbacks[topic](m.Wheels(t=t, left=0.0, right=0.0))
        wall[0] += 0.01
    client.subs["vps/pose"]("zenav/r1/vps/pose", b"\xc1")  # bad input: not a fix
    out = rec.stages()
    near, other = (out[f"localizer, {g}"] for g in AROUND_FIX)
    assert near == pytest.approx([3.0])  # sample 1
    assert other == pytest.approx([2.0] * 4)  # the rest, sample 3 too: its fix came 4.5 ms before
    assert out[f"{END_TO_END}, {AROUND_FIX[0]}"] == pytest.approx([6.0])  # 1 ms of it waiting for the fix
    assert len(rec.fixes) == 2


def test_near_fix_looks_back_from_each_arrival_in_any_order():
    arrivals = np.array([5.0, 1.0, 3.002, 2.0, 4.0])
    assert near_fix(arrivals, np.array([3.0, 0.999])).tolist() == [False, True, True, False, False]
    assert near_fix(arrivals, np.array([])).tolist() == [False] * 5
    assert near_fix(arrivals, np.array([9.0])).tolist() == [False] * 5
