"""The bench report from made-up results: every section, the targets' verdicts, the plot."""

from __future__ import annotations

from tests.support.bench import headings, results, sections
from zenav.bench import plan, report
from zenav.bench.run import Results


def test_every_section_and_target_is_written(tmp_path):
    path = report.write(results(), tmp_path)
    text = path.read_text()
    assert headings(text) == sections("default", "harsh")
    assert "| end to end p50 at 100 Hz | <= 3 ms | 3.00 ms | yes |" in text
    assert "| end to end p99 at 100 Hz | <= 8 ms | 8.88 ms | **no** |" in text
    assert "| whole bench run | < 120 s | 95 s | yes |" in text
    assert "| end to end p50, services as peers | <= 3 ms | 2.00 ms | yes |" in text
    assert "| router, services as peers |" in text
    assert "cores" in text and "GiB memory" in text and "eclipse-zenoh" in text and "`zenav bench --quick`" in text
    assert "at 2 it stopped keeping up" in text
    assert "aborted: no progress" in text  # failures are named
    assert (tmp_path / "latency.png").stat().st_size > 10_000


def test_an_empty_run_writes_only_the_header(tmp_path):
    res = Results(plan.only(plan.FULL, ["speed"]), "zenav bench --only speed", 1.7e9)
    text = report.write(res, tmp_path).read_text()
    assert "## Targets" in text and "## Latency" not in text and "## Navigation" not in text
