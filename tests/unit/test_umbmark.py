"""UMBmark: the fit recovers a robot's true track width and radius ratio from its squares' end errors."""

import math

import msgspec
import pytest

from zenav.common.config import RobotConfig
from zenav.common.scenarios import PRESETS
from zenav.services.driver import umbmark as u
from zenav.world.sim import SimRobot

NOMINAL = RobotConfig(wheel_diameter=0.0673, track_width=0.1156, ticks_per_rev=100_000)
GEOMETRY = u.Geometry(NOMINAL.track_width, NOMINAL.wheel_radius, NOMINAL.wheel_radius)
DT = 0.005  # [s] sim step


def square_error(clockwise: bool, scale: float, ratio: float, side: float = 1.0) -> tuple[float, float]:
    return u.end_error(u.square(side, clockwise, GEOMETRY.track), scale, ratio, GEOMETRY.track)


def test_the_nominal_robot_ends_where_it_started():
    for cw in (True, False):
        assert square_error(cw, 1.0, 1.0) == pytest.approx((0.0, 0.0), abs=1e-12)


def test_a_wider_track_turns_short_both_ways_mirrored():
    cw, ccw = square_error(True, 1.05, 1.0), square_error(False, 1.05, 1.0)
    assert cw[0] == pytest.approx(ccw[0]) and cw[1] == pytest.approx(-ccw[1])
    assert math.hypot(*cw) > 0.1  # about 4.5 deg short per turn over 1 m legs


@pytest.mark.parametrize("scale, ratio", [(1.05, 1.0), (0.97, 1.0), (1.0, 0.995), (1.03, 1.004)])
def test_fit_recovers_the_model_exactly(scale, ratio):
    runs = [u.Run(cw, u.square(1.0, cw, GEOMETRY.track), square_error(cw, scale, ratio)) for cw in (True, False)]
    f = u.fit(runs, GEOMETRY)
    assert f.track_scale == pytest.approx(scale, rel=1e-6) and f.ratio == pytest.approx(ratio, rel=1e-6)
    assert f.geometry.track == pytest.approx(GEOMETRY.track * scale, rel=1e-6) and f.rms < 1e-9
    assert (f.geometry.radius_left + f.geometry.radius_right) / 2 == pytest.approx(GEOMETRY.radius_left)


def test_fit_needs_both_directions():
    with pytest.raises(ValueError, match="clockwise"):
        u.fit([u.Run(True, u.square(1.0, True, GEOMETRY.track), (0.1, 0.0))], GEOMETRY)


def drive(sim: SimRobot, clockwise: bool, side: float, lag: int = 0) -> u.Run:
    """Drive the square on the sim by its encoders, each command applied `lag` steps late (a loaded link),
    until the wheels stand still; the run with its end error (true - believed) in the start frame [m]."""
    sq = u.Square(side, clockwise, GEOMETRY, NOMINAL.ticks_per_rev)
    sent = [(0.0, 0.0)] * lag
    for _ in range(round(60.0 / DT)):  # a 1 m square takes about 15 s
        sent.append(sq.step(*sim.encoders()))  # once done: (0, 0), and the counts of the coasting
        if sq.done and all(c == (0.0, 0.0) for c in sent) and abs(sim.state.v) + abs(sim.state.omega) < 1e-9:
            break
        sim.drive(*sent.pop(0), DT)
    assert sq.done
    s = sim.state
    return u.Run(clockwise, sq.trace, (s.x - sq.pose[0], s.y - sq.pose[1]))


@pytest.mark.parametrize("lag", [0, 40])
def test_a_simulated_robot_with_a_wrong_track_width_is_recovered(lag):
    """A robot whose track is 5 % wider and whose right wheel is 0.8 % smaller than believed, its commands
    on time or 0.2 s late (turns and legs overshoot: the fit replays them as driven)."""
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
    runs = [drive(SimRobot(NOMINAL, scen, seed=1), cw, side, lag) for cw in (True, False)]
    f = u.fit(runs, GEOMETRY)
    assert f.geometry.track == pytest.approx(NOMINAL.track_width * 1.05, rel=1e-5)  # the ideal square's model: 1e-3 at 0.2 s
    assert f.ratio == pytest.approx(0.996 / 1.004, abs=1e-5)
    assert f.rms < 1e-5
