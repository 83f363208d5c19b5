"""How well it localizes and drives: the accuracy, navigation, settle and camera sections."""

from __future__ import annotations

import math
import statistics
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from zenav.bench import camera as camera_bench
from zenav.bench.accuracy import Summary
from zenav.bench.scoring import summary
from zenav.bench.tables.markdown import failures, fmt, table
from zenav.common.config import Camera
from zenav.common.contract import GoalResult
from zenav.common.scenarios import HEADINGS, PATH
from zenav.services.vps.track import FULL_PERIOD

if TYPE_CHECKING:
    from zenav.bench.run import Results

PATH_TRIAL_ROBOT = "mean 11.4 / sd 3.9 cm with a 5 cm stopping threshold"  # the path trial's real robot (scenarios.md)


# ------------------------------------------------------------------ accuracy
def _cm(x: float) -> str:
    return fmt(x * 100)


def accuracy(res: Results) -> list[str]:
    lines = ["## Localization accuracy", ""]
    if res.modes:
        first = next(iter(res.modes.values()))
        lines += [
            f"Each fusion mode live in the stack ({first.spec.harness}), closed loop (the navigator drives on its pose): "
            "default scenario, "
            f"seed {first.spec.seed}, {first.spec.laps:g} lap(s) of the 1 m square, rtf {first.rtf:g}. Errors after "
            "a 2 s warm-up, against the truth at each pose's t. [cm, deg]",
            "",
        ]
        rows = []
        for mode, s in res.modes.items():
            corner = summary(s.errors["point"])
            rows.append(
                [
                    mode,
                    _cm(s.pose.rmse),
                    _cm(s.pose.max),
                    _cm(s.pose.final),
                    fmt(math.degrees(s.pose.heading_rmse)),
                    _cm(s.odom.rmse),
                    f"{_cm(corner[0])} / {_cm(corner[2])}",
                    str(len(s.failures)),
                    f"[plot](run_{mode}.png)",
                ]
            )
        lines += table(
            ["mode", "RMSE", "max", "final", "heading RMSE", "odom RMSE", "corner error mean / max", "goals failed", "trajectory"], rows
        )
        lines += failures(res.modes.items())
    for scenario in dict.fromkeys(sc for sc, _ in res.scenarios):
        runs = [s for (sc, _), s in res.scenarios.items() if sc == scenario]
        lines += ["", f"### {scenario}", "", _replay_intro(scenario, runs), ""]
        live = [(s.pose.rmse, s.pose.max, s.pose.final, s.pose.heading_rmse, None) for s in runs]
        rows = [_score_row("**live** (configured mode)", live)]
        for mode in runs[0].replay:
            sc = [s.replay[mode] for s in runs]
            rows.append(
                _score_row(
                    mode,
                    [(x.rmse, x.max, x.final, x.heading_rmse, x.outage_end) for x in sc],
                    sum(x.fixes_accepted or 0 for x in sc),
                    sum(x.fixes_rejected or 0 for x in sc),
                )
            )
        lines += table(
            ["mode", "RMSE mean (sd)", "max", "final mean", "heading RMSE [deg]", "error at outage end", "fixes accepted / rejected"], rows
        )
        if f"run_{scenario}.png" in res.plots:
            lines += ["", f"![{scenario}](run_{scenario}.png)"]
    if res.modes:
        lines += [""] + [f"![{mode}](run_{mode}.png)" for mode in res.modes]
    return lines


def _replay_intro(scenario: str, runs: Sequence[Summary]) -> str:
    return (
        f"Seeds {[s.spec.seed for s in runs]}, {runs[0].spec.laps:g} lap(s) of the square each, {runs[0].spec.harness}, "
        f"rtf {runs[0].rtf:g}. The "
        "live row is the configured mode in the stack; every mode below is fed offline with the same run's odometry, "
        "fixes (at the times the localizer received them) and sensors (the localizer study), so the "
        "rules are compared on the same data. RMSE mean over seeds (sd), max over seeds. [cm]"
    )


def _score_row(name: str, scores: Sequence[tuple[Any, ...]], accepted: int | None = None, rejected: int | None = None) -> list[str]:
    rmse = [s[0] for s in scores]
    outage = [s[4] for s in scores if s[4] is not None]
    return [
        name,
        f"{_cm(statistics.fmean(rmse))} ({_cm(statistics.stdev(rmse) if len(rmse) > 1 else 0.0)})",
        _cm(max(s[1] for s in scores)),
        _cm(statistics.fmean(s[2] for s in scores)),
        fmt(math.degrees(statistics.fmean(s[3] for s in scores))),
        _cm(statistics.fmean(outage)) if outage else "-",
        "-" if accepted is None else f"{accepted} / {rejected}",
    ]


# ------------------------------------------------------------------ navigation
def _spread(values: Sequence[float], digits: int = 2) -> str:
    m, sd, mx = summary(values)
    return f"{fmt(m, digits)} / {fmt(sd, digits)} / {fmt(mx, digits)}"


def navigation(res: Results) -> list[str]:
    rtf = next(iter(res.paths.values()))[0].rtf
    rows = []
    for ctrl, runs in res.paths.items():
        errs = [e * 100 for s in runs for e in s.errors["path"]]
        times = [d for s in runs for d in s.durations["path"]]
        failed = sum(not s.errors["path"] for s in runs)
        rows.append([ctrl, "stack", str(len(runs)), _spread(errs), _spread(times, 1), str(failed)])
        kin = res.kinematic.get(ctrl, [])
        if kin:
            errs = [100 * math.dist((o.x, o.y), PATH[-1]) for o in kin]
            failed = sum(o.result != GoalResult.SUCCEEDED for o in kin)
            rows.append([ctrl, "kinematic", str(len(kin)), _spread(errs), _spread([o.duration for o in kin], 1), str(failed)])
    lines = [
        "## Navigation",
        "",
        f"The path trial: from (0, 0, 0) follow (1, 0) -> (1, 1), default scenario, tolerance as configured; "
        f"final truth error to (1, 1). `stack`: the whole stack at rtf {rtf:g}, seeds {list(res.plan.path_seeds)}; "
        "`kinematic`: the navigator's goal machine on a kinematic robot with the scenario's motors and wheels, "
        f"true pose (the navigator study). The trial's real robot (docs/provenance.md): {PATH_TRIAL_ROBOT}.",
        "",
        *table(["controller", "loop", "runs", "error mean / sd / max [cm]", "time mean / sd / max [s]", "failed"], rows),
        *failures((f"{ctrl} seed {s.spec.seed}", s) for ctrl, runs in res.paths.items() for s in runs),
    ]
    if res.squares:
        rows = [
            [ctrl, _spread([e * 100 for e in s.errors["point"]]), fmt(sum(s.durations["point"]), 1), _cm(s.pose.rmse), str(len(s.failures))]
            for ctrl, s in res.squares.items()
        ]
        laps = next(iter(res.squares.values())).spec.laps
        lines += ["", f"The square trial: move_to_point around the 1 m square, {laps:g} laps, stack at rtf {rtf:g}.", ""]
        header = ["controller", "corner error mean / sd / max [cm]", "total time [s]", "pose RMSE [cm]", "goals failed"]
        lines += table(header, rows)
        lines += failures(res.squares.items())
    lines += ["", *_turns(res)]
    return lines


def _turns(res: Results) -> list[str]:
    runs = [s for runs in res.paths.values() for s in runs]
    errs = [math.degrees(e) for s in runs for e in s.errors["turn"]]
    failed = sum(len(HEADINGS) - len(s.errors["turn"]) for s in runs)
    m, sd, mx = summary(errs)
    return [
        f"Turns: after each path trial, turn_to_heading to {', '.join(f'{h:g}' for h in HEADINGS)} deg in turn; true "
        f"heading error at each success over {len(errs)} turns: mean {fmt(m)}, sd {fmt(sd)}, max {fmt(mx)} deg; "
        f"{failed} turn(s) did not succeed.",
    ]


# ------------------------------------------------------------------ settle
def settle(res: Results) -> list[str]:
    """How every kind of move ends, against the truth, with each pose error (bench/settle.py)."""
    lines = [
        "## Settle table",
        "",
        "The navigator's goal machine on the world model's robot (the navigator study's harness), each move from "
        "(0, 0, 0) at the default tolerances, fed the truth plus a pose error that jumps at the VPS rate. Errors are "
        "the true final pose to the goal; the arrival swing is the largest true heading change over the last 5 cm "
        "travelled (for a pose, its final turn in place included).",
    ]
    for name, text in res.settle.items():
        lines += ["", f"### With {name}", "", text]
    return lines


# ------------------------------------------------------------------ camera
def camera(res: Results) -> list[str]:
    """The overhead camera: its frames timed and read, then the whole stack with it against the synthetic VPS."""
    lines = ["## Overhead camera", ""]
    if res.cameras:
        lines += [
            "Frames rendered by the sim's camera model from known poses, read by the vps's pipeline (decode, "
            "pupil-apriltags, undistort, the plane homography of a calibration fitted to the fixed tags).",
            "",
            *camera_bench.lines(res.cameras, res.plan.camera_frames),
        ]
    if res.window is not None:
        lines += [
            "",
            "A 1280x720 camera (the default's view), two robots moving, 10 Hz: the vps "
            "looks for each robot's tag in a window round its predicted place, the whole frame every "
            f"{FULL_PERIOD:g} s (after the frame's fixes are out) and at once when a tag is not in its window; beside it, "
            "a reader that searches every frame whole, on the same frames. Frames/s per core: one over the CPU a frame "
            "takes; frame to fix: wall time from the frame's message to its fixes. Goals: >= 120 frames/s per core, "
            "frame to fix p95 < 10 ms, no fix lost.",
            "",
            f"- {res.window.line()}",
        ]
    if res.camera_runs:
        rtf, cam = next(iter(res.camera_runs.values()))[0][1].rtf, Camera()  # the runs' [camera] is the default
        lines += [
            "",
            f"The whole stack, one process per service, rtf {rtf:g}: each trial with the synthetic VPS (the truth plus the "
            f"scenario's VPS errors: the reference scenarios' VPS) and with the camera VPS (the sim renders {cam.rate_hz:g} "
            f"frames a second, the vps detects the robot's tag, {cam.link_delay:g} s link delay; the scenario's odometry "
            "errors and faults either way). Goal error: the truth at each goal's end to its point (square corners, the "
            "path's end). [cm, deg]",
            "",
        ]
        rows = []
        for trial, pairs in res.camera_runs.items():
            for k, source in enumerate(("synthetic", "camera")):
                runs = [p[k] for p in pairs]
                goals = [e for s in runs for e in s.errors["path" if s.spec.trial == "path" else "point"]]
                rmse = [s.pose.rmse for s in runs]
                rows.append(
                    [
                        trial,
                        source,
                        str(len(runs)),
                        f"{_cm(statistics.fmean(rmse))} / {_cm(max(rmse))}",
                        fmt(math.degrees(statistics.fmean(s.pose.heading_rmse for s in runs))),
                        _spread([e * 100 for e in goals]),
                        str(sum(len(s.failures) for s in runs)),
                    ]
                )
        header = ["trial", "VPS", "runs", "pose RMSE mean / max", "heading RMSE", "goal error mean / sd / max", "goals failed"]
        lines += table(header, rows)
        labelled = [(f"{trial} {s.spec.vps} seed {s.spec.seed}", s) for trial, pairs in res.camera_runs.items() for p in pairs for s in p]
        lines += failures(labelled)
    return lines
