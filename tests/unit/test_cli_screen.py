"""The status table of `zenav up`, `status` and `watch` (pure formatting)."""

import msgspec

from zenav.cli.screen import pose_line, service_rows
from zenav.common import messages as m


def diag(service: str, cpu: float | None, **counters: int) -> m.Diag:
    counters = {"msgs_in": 7, "msgs_out": 3, **counters}
    return m.Diag(t=1.0, service=service, uptime=1.0, counters=counters, rates={}, status="ok", cpu=cpu)


def test_each_service_shows_its_process_cpu_as_a_share_of_one_core():
    rows = service_rows(["motor", "vps", "sim"], {"motor": diag("motor", 0.0412), "vps": diag("vps", None)}, {"motor", "vps"})
    header, motor, vps, sim = (r.split() for r in rows)
    assert header[7] == "cpu" and motor[7] == "4.1%" and motor[4] == "7/3"
    assert vps[7] == "-"  # a service that does not report it
    assert sim[1] == "NO" and sim[7] == "-"  # nothing heard from it


def test_input_let_go_unserved_shows_beside_bad_input():
    slow = diag("navigator", 0.05, bad_input=2, dropped_superseded=40, dropped_stale=1, dropped_overflow=3, oversize=1, errors=9)
    header, nav = (r.split() for r in service_rows(["navigator"], {"navigator": slow}, {"navigator"}))
    assert header[5:7] == ["bad", "dropped"] and nav[5:7] == ["2", "45"]  # a handler's errors are not input let go
    _, quiet = (r.split() for r in service_rows(["motor"], {"motor": diag("motor", 0.01)}, {"motor"}))
    assert quiet[5:7] == ["0", "0"]


def test_each_input_rate_shows_what_serving_one_message_took():
    d = msgspec.structs.replace(diag("localizer", 0.05), rates={"odom": 100.0, "pose": 99.6}, serve={"odom": 161.4})
    header, row = service_rows(["localizer"], {"localizer": d}, {"localizer"})
    assert header.endswith("rates [Hz] (serving one [us])")
    assert row.endswith("odom 100 (161 us), pose 100")  # pose is an output: nothing served


def test_a_pose_whose_wheels_slip_says_so():
    truth = m.Truth(t=1.0, x=0.5, y=0.0, theta=0.0, v=0.0, omega=0.0, wall=0.0)
    pose = m.Pose(t=1.0, x=0.52, y=0.0, theta=0.0, v=0.1, omega=0.0)
    assert "SLIPPING" not in pose_line("pose", pose, truth)
    line = pose_line("pose", m.Pose(t=1.0, x=0.52, y=0.0, theta=0.0, v=0.1, omega=0.0, slipping=True), truth)
    assert "vs truth   2.00 cm" in line and line.endswith("SLIPPING (held or pushed?)")
