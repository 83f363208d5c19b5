"""The status table of `zenav up`, `status` and `watch` (pure formatting)."""

from zenav.cli.screen import service_rows
from zenav.common import messages as m


def diag(service: str, cpu: float | None) -> m.Diag:
    return m.Diag(t=1.0, service=service, uptime=1.0, counters={"msgs_in": 7, "msgs_out": 3}, rates={}, status="ok", cpu=cpu)


def test_each_service_shows_its_process_cpu_as_a_share_of_one_core():
    rows = service_rows(["motor", "vps", "sim"], {"motor": diag("motor", 0.0412), "vps": diag("vps", None)}, {"motor", "vps"})
    header, motor, vps, sim = (r.split() for r in rows)
    assert header[6] == "cpu" and motor[6] == "4.1%" and motor[4] == "7/3"
    assert vps[6] == "-"  # a service that does not report it
    assert sim[1] == "NO" and sim[6] == "-"  # nothing heard from it
