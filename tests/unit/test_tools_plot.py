"""Plots: errors against interpolated truth, and the PNG the benchmark and `zenav plot` write."""

from __future__ import annotations

import math

import numpy as np
import pytest

from zenav.tools.plot import errors, plot_run, rms

PNG = b"\x89PNG\r\n\x1a\n"


def circle(n: int = 200, dt: float = 0.1, r: float = 1.0) -> list[tuple[float, float, float, float]]:
    """Truth on a circle, heading tangent (crosses +-pi)."""
    out = []
    for i in range(n):
        a = i * dt * 0.5
        out.append((i * dt, r * math.sin(a), r * (1 - math.cos(a)), math.atan2(math.sin(a), math.cos(a))))
    return out


def test_errors_interpolate_truth_at_the_estimate_time():
    truth = [(0.0, 0.0, 0.0, 0.0), (1.0, 1.0, 0.0, 0.0)]
    t, pos, th = errors([(0.25, 0.25, 0.1, 0.0), (0.5, 0.6, 0.0, 0.2)], truth)
    assert list(t) == [0.25, 0.5]
    assert pos == pytest.approx([0.1, 0.1])
    assert th == pytest.approx([0.0, 0.2])


def test_heading_error_wraps_across_pi():
    truth = [(0.0, 0.0, 0.0, math.radians(179)), (1.0, 0.0, 0.0, math.radians(179))]
    _, _, th = errors([(0.5, 0.0, 0.0, math.radians(-179))], truth)
    assert math.degrees(th[0]) == pytest.approx(2.0)
    # truth itself crossing pi is unwrapped before interpolating
    truth = [(0.0, 0.0, 0.0, math.radians(178)), (1.0, 0.0, 0.0, math.radians(-178))]
    _, _, th = errors([(0.5, 0.0, 0.0, math.pi)], truth)
    assert th[0] == pytest.approx(0.0, abs=1e-9)


def test_samples_outside_the_truth_span_are_left_out():
    t, pos, _ = errors([(-1.0, 0, 0, 0), (0.5, 0, 0, 0), (3.0, 0, 0, 0)], [(0.0, 0, 0, 0), (1.0, 0, 0, 0)])
    assert list(t) == [0.5] and len(pos) == 1
    assert len(errors([], [(0.0, 0, 0, 0), (1.0, 0, 0, 0)])[0]) == 0
    assert rms(np.array([3.0, 4.0])) == pytest.approx(math.sqrt(12.5))


def test_plot_run_writes_a_png(tmp_path):
    truth = circle()
    odom = [(t, x * 1.05, y, th) for t, x, y, th in truth]
    pose = [(t, x + 0.01, y, th + 0.01) for t, x, y, th in truth]
    fixes = [(t, x + 0.02, y - 0.02, th) for t, x, y, th in truth[::10]]
    out = tmp_path / "run.png"
    plot_run(str(out), truth, odom, pose, fixes, title="circle")
    assert out.read_bytes()[:8] == PNG and out.stat().st_size > 20_000


def test_plot_run_without_truth_draws_the_trajectories(tmp_path):
    out = tmp_path / "real.png"
    plot_run(str(out), [], odom=circle(), pose=circle())
    assert out.read_bytes()[:8] == PNG
