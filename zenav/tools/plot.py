"""Trajectory and error-over-time plots of a run (truth, odom, fused pose, VPS fixes).

Pure functions over time series of (t [s], x [m], y [m], theta [rad]) samples, drawn
with matplotlib's Agg canvas (no display, no global pyplot state): `zenav plot`
feeds them from a recording, the benchmark from its runs. Errors are against the
truth interpolated at each sample's t, so odom (t = encoder sample), pose (t = odom
t) and fixes (t = capture time) are each judged at the instant they describe. Odom
is drawn in the map frame as it is: its frame starts where the robot starts.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from zenav.common.track import Sample, Track
from zenav.tools import mcap_format as fmt

Series = Sequence[Sample]

STYLE = {  # series -> (label, colour)
    "truth": ("truth", "black"),
    "odom": ("odom", "tab:orange"),
    "pose": ("fused", "tab:blue"),
    "fixes": ("VPS fixes", "tab:purple"),
}


@dataclass
class Run:
    """The time series of one robot's run."""

    truth: list[Sample] = field(default_factory=list)
    odom: list[Sample] = field(default_factory=list)
    pose: list[Sample] = field(default_factory=list)
    fixes: list[Sample] = field(default_factory=list)


OUTLIER_ROOM = 1.3  # the position axis goes this far above the 95th percentile of the fix errors

TOPIC_SERIES = {"sim/truth": "truth", "odom": "odom", "pose": "pose", "vps/pose": "fixes"}


def load(path: str, robot: str | None = None) -> Run:
    """The series of one robot (default: the first in the file) from an MCAP recording."""
    if robot is None:
        found = fmt.robots(path)
        if not found:
            raise ValueError(f"{path}: no zenav topics in this recording")
        robot = found[0]
    run = Run()
    for rec in fmt.read(path, robot, TOPIC_SERIES):
        series = getattr(run, TOPIC_SERIES[rec.suffix])
        series.append((rec.msg.t, rec.msg.x, rec.msg.y, rec.msg.theta))
    return run


def errors(est: Series, truth: Series) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t, position error [m], heading error [rad]) of `est` against truth interpolated at its t.

    Samples outside the truth's time span are left out.
    """
    if len(truth) < 2:
        return np.empty(0), np.empty(0), np.empty(0)
    return Track(truth).errors(est)


def rms(values: np.ndarray) -> float:
    """Root mean square (nan for no values)."""
    return float(np.sqrt(np.mean(np.square(values)))) if len(values) else float("nan")


def plot_run(out: str, truth: Series, odom: Series = (), pose: Series = (), fixes: Series = (), title: str = "") -> None:
    """Write a PNG: the trajectories (equal axes), and position and heading error over time."""
    fig = Figure(figsize=(13, 6), layout="constrained")
    FigureCanvasAgg(fig)
    grid = fig.add_gridspec(2, 2, width_ratios=(1.1, 1))
    ax_xy = fig.add_subplot(grid[:, 0])
    ax_pos = fig.add_subplot(grid[0, 1])
    ax_th = fig.add_subplot(grid[1, 1], sharex=ax_pos)

    for name, series in (("truth", truth), ("odom", odom), ("pose", pose)):
        if series:
            label, colour = STYLE[name]
            xy = np.array(series)[:, 1:3]
            ax_xy.plot(xy[:, 0], xy[:, 1], color=colour, lw=2.2 if name == "truth" else 1.4, label=label, alpha=0.9)
            ax_xy.plot(xy[0, 0], xy[0, 1], "o", color=colour, ms=5)
    if fixes:
        label, colour = STYLE["fixes"]
        xy = np.array(fixes)[:, 1:3]
        ax_xy.scatter(xy[:, 0], xy[:, 1], s=6, color=colour, alpha=0.5, label=label, zorder=1)
    ax_xy.set_aspect("equal", adjustable="datalim")
    ax_xy.set(xlabel="x [m]", ylabel="y [m]", title="trajectory (map frame)")
    ax_xy.grid(alpha=0.3)
    ax_xy.legend(loc="best")

    t0 = min((s[0][0] for s in (truth, odom, pose, fixes) if s), default=0.0)
    curves = {name: errors(series, truth) for name, series in (("fixes", fixes), ("odom", odom), ("pose", pose))}
    # The position axis shows every odom and fused error and 95 % of the fixes: a few
    # outlier fixes half a metre off would flatten everything else.
    tops = [float(np.max(pos)) for name, (_, pos, _) in curves.items() if name != "fixes" and len(pos)]
    if len(curves["fixes"][1]):
        tops.append(float(np.percentile(curves["fixes"][1], 95)) * OUTLIER_ROOM)
    top = max(tops, default=0.0) * 100 * 1.05  # [cm]
    for name, (t, pos, th) in curves.items():
        if not len(t):
            continue
        label, colour = STYLE[name]
        stats = f"{label}: rms {rms(pos) * 100:.1f} cm, {math.degrees(rms(th)):.1f} deg"
        if name == "fixes":
            above = int(np.sum(pos * 100 > top))
            stats += f" ({above} off the chart)" if above else ""
            ax_pos.scatter(t - t0, pos * 100, s=6, color=colour, alpha=0.5, label=stats)
            ax_th.scatter(t - t0, np.degrees(th), s=6, color=colour, alpha=0.5)
        else:
            ax_pos.plot(t - t0, pos * 100, color=colour, lw=1.2, label=stats)
            ax_th.plot(t - t0, np.degrees(th), color=colour, lw=0.7, alpha=0.8)
    if not truth:
        ax_pos.text(0.5, 0.5, "no ground truth (sim/truth) to compare with", ha="center", va="center", transform=ax_pos.transAxes)
    ax_pos.set(ylabel="position error [cm]", title="error against truth")
    ax_th.set(xlabel="t [s]", ylabel="heading error [deg]")
    for ax in (ax_pos, ax_th):
        ax.grid(alpha=0.3)
        ax.set_ylim(bottom=0)
    if top > 0:
        ax_pos.set_ylim(top=top)
    if ax_pos.has_data():
        ax_pos.legend(loc="upper left", fontsize="small")
    if title:
        fig.suptitle(title)
    fig.savefig(out, dpi=100)


def plot_file(path: str, out: str, robot: str | None = None, title: str | None = None) -> Run:
    """Plot a recording to a PNG; returns the series it read."""
    run = load(path, robot)
    if not (run.truth or run.odom or run.pose or run.fixes):
        raise ValueError(f"{path}: no sim/truth, odom, pose or vps/pose messages")
    plot_run(out, run.truth, run.odom, run.pose, run.fixes, title=title if title is not None else path)
    return run
