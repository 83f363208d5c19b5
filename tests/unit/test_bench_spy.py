"""The deployed profile: py-spy's raw samples read, and written into the profile section."""

from __future__ import annotations

from collections import Counter

from tests.support.bench import results
from zenav.bench import report, spy
from zenav.bench.profile import Cost

RAW = """\
thread (4642): rx-0;_enqueue (zenav/common/runtime.py:681);_serve (zenav/common/runtime.py:540);\
on_odom (zenav/services/localizer/service.py:42) 30
thread (4642): rx-0;_enqueue (zenav/common/runtime.py:681);publish (zenav/common/runtime.py:328) 10
thread (4650): MainThread;run (zenav/common/runtime.py:467);run (zenav/common/runtime.py:467) 5
thread (4651);tick (zenav/common/clock.py:90) 2
thread (4652): Dummy-1;tick (zenav/common/clock.py:90) 1
this line is not a sample
"""


def test_raw_samples_are_counted_by_thread_innermost_function_and_stack():
    s = spy.parse(RAW, comm={4652: "rx-1", 4642: "not this"})
    assert s.samples == 48
    # a thread Python has a name for keeps it; one without (or Dummy-N) takes its OS name, else keeps its id
    assert s.threads == Counter({"rx-0": 40, "MainThread": 5, "thread (4651)": 2, "rx-1": 1})
    assert s.own.most_common(1) == [("on_odom (zenav/services/localizer/service.py:42)", 30)]
    assert s.own["publish (zenav/common/runtime.py:328)"] == 10
    # with callees: every sample the function is on; a recursive one counted once a sample
    assert s.total["_enqueue (zenav/common/runtime.py:681)"] == 40
    assert s.total["run (zenav/common/runtime.py:467)"] == 5


def test_the_deployed_samples_are_written_as_cores_and_us_per_period(tmp_path):
    d = spy.Deployed(sampled=10, rate=500, cores={"localizer": 0.05}, spied={"localizer": spy.parse(RAW)})
    # 48 samples at 500 Hz over 10 s: 0.0096 s active a second; per 10 ms period: 96 us; on_odom's 30: 60 us
    assert abs(d.active(48) - 0.0096) < 1e-12 and abs(d.per_period(30) - 60.0) < 1e-9
    res = results()
    res.costs = {n: Cost(n, 100, 100, 100, 0.005) for n in ("odometry", "localizer", "navigator", "motor")}
    res.spied = d
    text = report.write(res, tmp_path).read_text()
    assert "### As deployed" in text
    assert "| localizer | 0.050 | 0.010 | rx-0 0.008, MainThread 0.001, thread (4651) 0.000, thread (4652) 0.000 |" in text
    assert "| 60.0 | 60.0 | `on_odom (zenav/services/localizer/service.py:42)` |" in text
    res.spied = "py-spy is not installed (pip install py-spy)"
    assert "Not sampled: py-spy is not installed (pip install py-spy)." in report.write(res, tmp_path).read_text()
