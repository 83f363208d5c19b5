"""A VPS without capture stamps, through the services: vps stamp = "none", localizer latency = "estimate"."""

from __future__ import annotations

import pytest

from tests.support.rig import Rig
from zenav.bench.studies.localizer import drive_square
from zenav.common import messages as m
from zenav.common.scenarios import scenario
from zenav.services.localizer.service import Localizer
from zenav.services.vps.service import Vps

CLEAN = {"vps_noise_xy": 0.0, "vps_noise_theta_deg": 0.0, "vps_drop": 0.0, "vps_outlier": 0.0, "vps_jitter": 0.0}


def test_vps_without_capture_stamps_stamps_on_sending():
    rig = Rig(Vps, scenario=CLEAN, vps={"stamp": "none"})
    for k in range(100):  # 1 s of truth at 100 Hz
        rig.clock.t = t = k * 0.01
        rig.put("sim/truth", m.Truth(t=t, x=0.3 * t, y=0.0, theta=0.0, v=0.3, omega=0.0))
    out = rig.got("vps/pose")
    assert len(out) == 7
    for f in out:  # t is the sending time; the position is the capture's, 0.3 s before
        assert f.t >= 0.3 - 1e-9 and f.x == pytest.approx(0.3 * (f.t - 0.3), abs=0.3 * 0.006)
    rig.close()


def test_localizer_estimates_the_latency_of_unstamped_fixes_and_reports_it():
    run = drive_square(scenario("default"), 5, duration=9.0)
    rig = Rig(Localizer, localizer={"latency": "estimate", "expected_latency": 0.2})
    for i, o in enumerate(run.odom):
        rig.clock.t = o.t
        for t_arr, f in run.fixes:
            if o.t - 0.01 < t_arr <= o.t:
                rig.put("vps/pose", m.VpsPose(t=t_arr, x=f.x, y=f.y, theta=f.theta, cov=f.cov))  # stamped on arrival
        rig.put("sensors/imu", run.imu[i])
        rig.put("odom", o)
    recs = rig.got("localizer/fixes")
    assert recs[0].latency_estimate == pytest.approx(0.2)  # the prior until the first window
    last = recs[-1]
    assert last.latency_estimate == pytest.approx(0.3, abs=0.03) and 0.0 < last.latency_sigma < 0.05
    d = rig.got("diag/localizer")[-1]
    assert "estimated" in d.message and "expected 0.200" in d.message
    rig.close()
