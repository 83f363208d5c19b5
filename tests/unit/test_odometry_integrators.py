"""The pose integrators against the closed form of circular arcs, and their Jacobians."""

import math

import numpy as np
import pytest

from zenav.services.odometry import integrators as ig

NAMES = ("euler", "midpoint", "rk4", "arc")


def closed_form(x0, y0, th0, s, turn):
    """Pose after travelling s [m] along a circle turning by `turn` [rad] (turn != 0)."""
    r = s / turn
    return x0 + r * (math.sin(th0 + turn) - math.sin(th0)), y0 - r * (math.cos(th0 + turn) - math.cos(th0)), th0 + turn


def integrate(name, x0, y0, th0, s, turn, n):
    x, y, th = x0, y0, th0
    for _ in range(n):
        x, y, th, _, _ = ig.step(x, y, th, s / n, turn / n, ig.INTEGRATORS[name])
    return x, y, th


def position_error(name, s, turn, n, start=(0.3, -0.2, 0.7)):
    x, y, th = integrate(name, *start, s, turn, n)
    ex, ey, eth = closed_form(*start, s, turn)
    assert math.isclose(math.cos(th - eth), 1.0, abs_tol=1e-12)  # heading is exact for all
    return math.hypot(x - ex, y - ey)


# (label, travel [m], turn [rad], steps): 1 m at 0.2 m/s turning at 0.5 rad/s sampled at
# 100 Hz, then the same arc at 10 Hz, then a tight curve with coarse steps.
ARCS = [
    ("1 m, 2.5 rad, 500 steps (100 Hz)", 1.0, 2.5, 500),
    ("1 m, 2.5 rad, 50 steps (10 Hz)", 1.0, 2.5, 50),
    ("0.5 m, 3 pi/2 rad, 12 steps", 0.5, 1.5 * math.pi, 12),
]


def test_error_table_on_known_arcs():
    """Global position error after the whole arc; euler is first order, midpoint second, rk4 fourth."""
    rows = {label: {name: position_error(name, s, turn, n) for name in NAMES} for label, s, turn, n in ARCS}
    print("\nintegrator error [m] on circular arcs vs the closed form")
    print(f"{'arc':34}" + "".join(f"{name:>12}" for name in NAMES))
    for label, errs in rows.items():
        print(f"{label:34}" + "".join(f"{errs[name]:12.2e}" for name in NAMES))
    for (_label, s, turn, n), errs in zip(ARCS, rows.values()):
        h = turn / n  # heading change per step [rad]
        chord = 2.0 * s / turn * math.sin(turn / 2.0)  # [m] start to end
        assert errs["arc"] < 1e-12
        # Each step's displacement is the exact one rotated by h/2 (euler), or scaled by
        # (h/2) / sin(h/2) ~ 1 + h^2/24 (midpoint), or by ~ 1 + h^4/2880 (rk4, Simpson).
        assert errs["euler"] == pytest.approx(chord * h / 2.0, rel=0.05)
        assert errs["midpoint"] == pytest.approx(chord * h * h / 24.0, rel=0.05)
        assert errs["rk4"] == pytest.approx(chord * h**4 / 2880.0, rel=0.05, abs=5e-14)  # + rounding
        assert errs["arc"] < errs["rk4"] < errs["midpoint"] < errs["euler"]


@pytest.mark.parametrize("name", NAMES)
def test_straight_line_is_exact(name):
    x, y, th = integrate(name, 1.0, 2.0, -2.0, 3.0, 0.0, 7)
    assert (x, y) == pytest.approx((1.0 + 3.0 * math.cos(-2.0), 2.0 + 3.0 * math.sin(-2.0)), abs=1e-12)
    assert th == -2.0


def test_arc_is_continuous_through_the_straight_line_limit():
    """Near dtheta = 0 the arc switches to its series; both sides match the integral of the heading."""
    nodes, weights = np.polynomial.legendre.leggauss(30)
    u = (nodes + 1.0) / 2.0  # Gauss-Legendre on [0, 1]: exact to rounding for these smooth integrands
    for dtheta in (0.0, 1e-12, 1e-6, 1.98e-3, 2.02e-3, 1e-2, 0.5):
        heading = 0.4 + dtheta * u
        a, b, da, db = ig.arc(0.4, dtheta)
        assert a == pytest.approx(np.sum(weights * np.cos(heading)) / 2.0, abs=1e-15)
        assert b == pytest.approx(np.sum(weights * np.sin(heading)) / 2.0, abs=1e-15)
        assert da == pytest.approx(-np.sum(weights * u * np.sin(heading)) / 2.0, abs=1e-12)
        assert db == pytest.approx(np.sum(weights * u * np.cos(heading)) / 2.0, abs=1e-12)


def test_rk4_is_the_seed_formula():
    """The Runge-Kutta paper's k00..k32 with its v, omega and t give the same step."""
    x, y, th, v, omega, t = 0.1, 0.2, 0.3, 0.25, 1.7, 0.05
    k00, k01, k02 = v * math.cos(th), v * math.sin(th), omega
    k10, k11, k12 = v * math.cos(th + t / 2 * k02), v * math.sin(th + t / 2 * k02), omega
    k20, k21, k22 = v * math.cos(th + t / 2 * k12), v * math.sin(th + t / 2 * k12), omega
    k30, k31, k32 = v * math.cos(th + t * k22), v * math.sin(th + t * k22), omega
    seed = (
        x + t / 6 * (k00 + 2 * (k10 + k20) + k30),
        y + t / 6 * (k01 + 2 * (k11 + k21) + k31),
        th + t / 6 * (k02 + 2 * (k12 + k22) + k32),
    )
    ours = ig.step(x, y, th, v * t, omega * t, ig.rk4)
    assert (ours.x, ours.y, ours.theta) == pytest.approx(seed, abs=1e-15)


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("theta, d, dtheta", [(0.3, 0.05, 0.2), (-2.9, 0.01, -0.003), (1.0, -0.02, 0.0), (2.0, 0.0, 0.4)])
def test_jacobians_match_finite_differences(name, theta, d, dtheta):
    f = ig.INTEGRATORS[name]

    def pose(v):  # v = (x, y, theta, d, dtheta) -> unwrapped new pose
        st = ig.step(v[0], v[1], v[2], v[3], v[4], f)
        return np.array([st.x, st.y, v[2] + v[4]])

    v0 = np.array([0.5, -0.4, theta, d, dtheta])
    eps = 1e-6
    num = np.column_stack([(pose(v0 + eps * e) - pose(v0 - eps * e)) / (2 * eps) for e in np.eye(5)])
    st = ig.step(*v0, f)
    assert st.F == pytest.approx(num[:, :3], abs=1e-8)
    assert st.G == pytest.approx(num[:, 3:], abs=1e-8)
