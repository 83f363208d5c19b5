"""The bench report from made-up results: every section, the targets' verdicts, the plot."""

from __future__ import annotations

from dataclasses import replace

from tests.support.bench import headings, live, results, sections, summary
from zenav.bench import camera as camera_bench
from zenav.bench import plan, report
from zenav.bench.accuracy import Spec
from zenav.bench.board import BoardRun
from zenav.bench.chain import Chain
from zenav.bench.latency import END_TO_END, STAGES, Stats
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


def test_a_chain_with_control_on_odom_is_written_without_the_localizer(tmp_path):
    res = results()
    for run in (res.base, res.peer):
        for name in [n for n in run.chain if n.startswith("localizer")]:
            del run.chain[name]  # the observer of a control loop on odom has no localizer stage
    text = report.write(res, tmp_path).read_text()
    latency = text[text.index("## Latency") :].split("\n### ")[0]
    assert "`sensors/encoders`, `odom`, `cmd_vel` and `motors/wheels`" in latency
    assert "| delivery | 3 |" in latency and "| navigator | 3 |" in latency and "| localizer | 3 |" not in latency
    around = text[text.index("### The localizer around a late fix") :].split("\n### ")[0]
    assert "| clients: odom within 3 ms after a fix | 2 | - | - | - |" in around  # end to end only


def test_an_empty_run_writes_only_the_header(tmp_path):
    res = Results(plan.only(plan.FULL, ["speed"]), "zenav bench --only speed", 1.7e9)
    text = report.write(res, tmp_path).read_text()
    assert "## Targets" in text and "## Latency" not in text and "## Navigation" not in text


def test_the_camera_section_compares_the_camera_vps_with_the_synthetic(tmp_path):
    res = Results(plan.only(plan.FULL, ["camera"]), "zenav bench --only camera", 1.7e9)
    timing = {k: camera_bench.Timing((5.0, 9.0), 4.0) for k in camera_bench.STAGES}
    accuracy = camera_bench.Accuracy(280, 280, (0.2, 0.3), (0.06, 0.2), (0.1, 0.2))
    res.cameras = {"default 640x480": camera_bench.Measured(timing, accuracy, (50, 50, 0), 0.0007)}
    path = Spec(trial="path")
    res.camera_runs = {"default, path": [(summary(path, 3.0, [1.0]), summary(replace(path, vps="camera"), 3.0, [1.0], ("timeout",)))]}
    text = report.write(res, tmp_path).read_text()
    assert headings(text) == ["# zenav benchmark", "## Targets", "## Overhead camera"]
    assert "| default 640x480 | 5.0 / 9.0 (4.0) | 5.0 / 9.0 (4.0) | 5.0 / 9.0 (4.0) | 0.70 |" in text
    assert "| default 640x480 | 280/280 | 0.20 / 0.30 | 0.06 / 0.20 | 0.10 / 0.20 |" in text
    assert "both fixed in 50/50 frames, fixes given to the wrong robot: 0" in text
    assert "| default, path | synthetic | 1 | 1.00 / 1.00 | 0.57 | 0.50 / 0.00 / 0.50 | 0 |" in text
    assert "| default, path | camera | 1 | 1.00 / 1.00 | 0.57 | 0.50 / 0.00 / 0.50 | 1 |" in text
    assert "- default, path camera seed 1: timeout" in text


def test_the_robot_profiles_deployments_on_the_emulated_board_are_a_table_of_the_cost_section(tmp_path):
    res = results()
    res.plan = replace(res.plan, board_window=20.0)  # the full run's part
    res.boards = {
        "every service its own process": BoardRun({"router": 0.02, "driver": 0.06, "vps": 0.10}, 100.0, Stats.of([2.0, 3.0]), [], (95, 2)),
        "all six in one process": BoardRun({"router": 0.01, "composed": 0.064}, 99.6, Stats.of([]), ["(0.5, 0.0): aborted"]),
    }
    text = report.write(res, tmp_path).read_text()
    assert "### The robot computer: the robot profile and its camera on the emulated board (20 s windows)" in text
    assert "| every service its own process | **0.160** | driver 0.060, vps 0.100 | 0.020 | 100 | 2.50 / 2.99 | 95 / 2 | none |" in text
    assert "| all six in one process | **0.064** | composed 0.064 | 0.010 | 100 | - / - | 0 / 0 | (0.5, 0.0): aborted |" in text
    assert "robot computer: 0.160 core (every service its own process; goal 0.15)" in text  # the budget's lines
    assert "robot computer: 0.064 core (all six in one process; goal 0.08)" in text
    assert "| robot computer, every service its own process (router aside) | <= 0.15 core | 0.160 core | **no** |" in text
    assert "| robot computer, all six in one process (router aside) | <= 0.08 core | 0.064 core | yes |" in text


def test_the_settle_section_writes_a_table_per_pose_error(tmp_path):
    res = Results(plan.only(plan.FULL, ["settle"]), "zenav bench --only settle", 1.7e9)
    res.settle = {"the synthetic late VPS's pose error": "| move |\n|---|\n| point 0.3 m |", "the camera VPS's pose error": "| move |"}
    text = report.write(res, tmp_path).read_text()
    assert headings(text)[2:] == ["## Settle table", "### With the synthetic late VPS's pose error", "### With the camera VPS's pose error"]
    assert "| point 0.3 m |" in text


def test_the_busy_computer_table_has_a_row_per_run_and_says_why_when_not_run(tmp_path):
    res = results()
    text = report.write(res, tmp_path).read_text()
    assert "| idle, normal priority (the run above) | 3 | 3.00 |" in text
    assert "| one core busy, normal priority | 3 | 6.00 | 14.00 | 15.80 | 16.00 | 30 |" in text
    assert "| one core busy, real-time priority 10 | 3 |" in text and "`[deployment] realtime = 10`" in text
    res.busy, res.busy_refused = {}, "PermissionError: [Errno 1] Operation not permitted"
    text = report.write(res, tmp_path).read_text()
    assert "Not run: real-time priority refused on this host (PermissionError: [Errno 1] Operation not permitted)." in text
    assert "| one core busy" not in text


def test_the_targets_say_what_the_cpu_goals_stand_on_here(tmp_path):
    """The stack's messages at a bare relay's price each: the CPU the goals leave for the services' work."""
    bare = Chain({s: [1.0, 2.0, 3.0] for s in (*STAGES, END_TO_END)}, relay_cores=0.04, relay_wait=1e-4, relay_runs=500.0)
    text = report.write(replace(results(), chains={"client": bare}), tmp_path).read_text()
    # Every service takes 100 messages a second and sends 50, all but the sim 20 clock ticks (tests/support/bench.py);
    # a relay 100 and 100.
    assert (
        "CPU floor: a bare relay (one topic in and out at 100 Hz) took 0.040 of a core in this run. At its price per "
        "message, the 400 messages a second the robot's services take (and 80 sim clock ticks) and the 200 they send "
        "would cost 0.136 of a core with no work of theirs (goal 0.15), every stack process's but the router's 0.200 "
        "(goal for the whole stack, the router's 0.080 included: 0.3)."
    ) in text
    assert "CPU floor" not in report.write(results(), tmp_path).read_text()  # no bare chain run, no floor


def test_the_whole_stack_with_the_camera_vps_has_its_own_target_and_rows(tmp_path):
    res = results()
    res.camera_vps = live(cpu=0.3)
    text = report.write(res, tmp_path).read_text()
    assert "| whole stack CPU at 100 Hz, camera VPS | <= 0.3 core | 0.260 CPU s per simulated s | yes |" in text
    assert "| whole stack, camera VPS | 0.260 |" in text and "| vps, camera VPS | 0.030 |" in text
    res.camera_vps = live(cpu=0.5)
    text = report.write(res, tmp_path).read_text()
    assert "| whole stack CPU at 100 Hz, camera VPS | <= 0.3 core | 0.380 CPU s per simulated s | **no** |" in text
