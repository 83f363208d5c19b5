"""Two cameras, two vps: the localizer fuses the fixes of both, each at its own capture time, whatever its latency."""

import math

import numpy as np
import pytest

from tests.support.rig import Rig
from zenav.bench.studies.localizer import drive_square
from zenav.common import codec
from zenav.common import messages as m
from zenav.common.scenarios import scenario
from zenav.services.localizer.service import Localizer
from zenav.services.vps.service import Vps

FAST_LATENCY = 0.05  # [s] the onboard camera's: on the robot
FAST_SIGMA = 0.004  # [m]


@pytest.fixture(scope="module")
def run():
    return drive_square(scenario("default"), 7, duration=12.0)


def onboard_fixes(run) -> list[tuple[float, m.VpsPose]]:
    """(arrival, fix) of a second camera: 15 Hz, 50 ms late, 4 mm noise, from the truth."""
    rng = np.random.default_rng(3)
    cov = (FAST_SIGMA**2, 0.0, 0.0, 0.0, FAST_SIGMA**2, 0.0, 0.0, 0.0, 0.003**2)
    out = []
    for tr in run.truth[::7]:  # 100 Hz truth: every 70 ms
        dx, dy, dth = (float(v) for v in rng.normal(0.0, (FAST_SIGMA, FAST_SIGMA, 0.003)))
        out.append((tr.t + FAST_LATENCY, m.VpsPose(t=tr.t, x=tr.x + dx, y=tr.y + dy, theta=tr.theta + dth, cov=cov)))
    return out


def drive(run, fixes) -> tuple[float, Rig]:
    """The localizer fed odometry, the IMU and `fixes` on arrival; its position RMSE [m] after the first 2 s."""
    rig = Rig(Localizer)
    pending = sorted(fixes, key=lambda f: f[0])
    k = 0
    for i, o in enumerate(run.odom):
        rig.clock.t = o.t
        while k < len(pending) and pending[k][0] <= o.t:
            rig.put("vps/pose", pending[k][1])
            k += 1
        rig.put("sensors/imu", run.imu[i])
        rig.put("odom", o)
    errs = [math.hypot(p.x - tr.x, p.y - tr.y) for p, tr in zip(rig.got("pose"), run.truth) if p.t > 2.0]
    return math.sqrt(sum(e * e for e in errs) / len(errs)), rig


def test_the_fixes_of_two_cameras_of_different_latencies_are_all_fused(run):
    slow = list(run.fixes)  # the overhead camera: the default scenario's, ~0.3 s late
    alone, rig_slow = drive(run, slow)
    both, rig = drive(run, slow + onboard_fixes(run))
    records = rig.got("localizer/fixes")
    latencies = [r.latency for r in records if r.accepted]
    assert any(lat < 0.1 for lat in latencies) and any(lat > 0.2 for lat in latencies)  # both cameras' fixes used
    assert rig.svc.counters.values.get("fixes_out_of_order", 0) > 0  # a slow fix older than a fast one: applied all the same
    assert both < alone  # the second camera makes the pose better
    rig.close()
    rig_slow.close()


def test_a_second_cameras_vps_runs_under_its_own_name():
    rig = Rig(Vps, vps={"name": "onboard"})
    assert rig.svc.name == "vps_onboard"
    rig.run(1.5)
    diags = [codec.decode(d, m.Diag) for k, d in rig.bus.published if k == rig.key("diag/vps_onboard")]
    assert diags and diags[-1].service == "vps_onboard" and not rig.got("diag/vps")
    rig.close()
