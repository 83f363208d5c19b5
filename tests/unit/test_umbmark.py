"""UMBmark: the fit recovers a robot's true track width and radius ratio from its squares' end errors."""

import math

import msgspec
import pytest

from zenav.common.config import Robot
from zenav.common.scenarios import PRESETS
from zenav.services.driver import umbmark as u
from zenav.world.sim import SimRobot

NOMINAL = Robot(wheel_diameter=0.0673, track_width=0.1156, ticks_per_rev=100_000)
GEOMETRY = u.Geometry(NOMINAL.track_width, NOMINAL.wheel_radius, NOMINAL.wheel_radius)
DT = 0.005  # [s] sim step


def test_the_nominal_robot_ends_where_it_started():
    for cw in (True, False):
        assert u.end_error(1.0, cw, 1.0, 1.0, 0.1156) == pytest.approx((0.0, 0.0), abs=1e-12)


def test_a_wider_track_turns_short_both_ways_mirrored():
    cw, ccw = u.end_error(1.0, True, 1.05, 1.0, 0.1156), u.end_error(1.0, False, 1.05, 1.0, 0.1156)
    assert cw[0] == pytest.approx(ccw[0]) and cw[1] == pytest.approx(-ccw[1])
    assert math.hypot(*cw) > 0.1  # about 4.5 deg short per turn over 1 m legs


@pytest.mark.parametrize("scale, ratio", [(1.05, 1.0), (0.97, 1.0), (1.0, 0.995), (1.03, 1.004)])
def test_fit_recovers_the_model_exactly(scale, ratio):
    side = 1.0
    cw = [u.end_error(side, True, scale, ratio, GEOMETRY.track)]
    ccw = [u.end_error(side, False, scale, ratio, GEOMETRY.track)]
    f = u.fit(side, cw, ccw, GEOMETRY)
    assert f.track_scale == pytest.approx(scale, rel=1e-6) and f.ratio == pytest.approx(ratio, rel=1e-6)
    assert f.geometry.track == pytest.approx(GEOMETRY.track * scale, rel=1e-6) and f.rms < 1e-9
    assert (f.geometry.radius_left + f.geometry.radius_right) / 2 == pytest.approx(GEOMETRY.radius_left)


def test_fit_needs_both_directions():
    with pytest.raises(ValueError, match="clockwise"):
        u.fit(1.0, [(0.1, 0.0)], [], GEOMETRY)


def drive(sim: SimRobot, clockwise: bool, side: float) -> tuple[float, float]:
    """Drive the square on the sim by its encoders; the end error (true - believed) in the start frame [m]."""
    sq = u.Square(side, clockwise, GEOMETRY, NOMINAL.ticks_per_rev)
    for _ in range(round(60.0 / DT)):  # a 1 m square takes about 15 s
        v, omega = sq.step(*sim.encoders())
        if sq.done:
            break
        sim.drive(v, omega, DT)
    assert sq.done
    s = sim.state
    return s.x - sq.pose[0], s.y - sq.pose[1]


def test_a_simulated_robot_with_a_wrong_track_width_is_recovered():
    """A robot whose track is 5 % wider and whose right wheel is 0.8 % smaller than believed."""
    scen = msgspec.structs.replace(
        PRESETS["default"],
        track_width_err=0.05,
        wheel_radius_err_left=0.004,
        wheel_radius_err_right=-0.004,
        slip_sigma=0.0,
        motor_deadband=0.0,
        ticks_per_rev=NOMINAL.ticks_per_rev,
    )
    side = 1.0
    errs = {cw: drive(SimRobot(NOMINAL, scen, seed=1), cw, side) for cw in (True, False)}
    f = u.fit(side, [errs[True]], [errs[False]], GEOMETRY)
    assert f.geometry.track == pytest.approx(NOMINAL.track_width * 1.05, rel=0.001)
    assert f.ratio == pytest.approx(0.996 / 1.004, abs=1e-4)
    assert f.rms < 0.001
