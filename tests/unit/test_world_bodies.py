"""Robots' bodies as discs: a step into another body or a wall stops at contact, slides round it, and never pushes it.
A chassis against the walls: no corner past one, and a robot driven into one squares up against it."""

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from zenav.common.config import RobotConfig
from zenav.world.bodies import Chassis, Disc, Walls, _corners, _nearest, block, chassis_inside, chassis_travel
from zenav.world.robot import arc
from zenav.world.sim import SimRobot

from .test_world_sim import IDEAL

OTHER = {"r2": Disc(0.5, 0.0, 0.1)}
FIELD = Walls(-1.0, 1.0, -1.0, 1.0)


def test_a_step_that_would_overlap_another_body_ends_at_contact():
    assert block(0.25, 0.0, 0.35, 0.0, 0.1, OTHER) == (pytest.approx(0.3), pytest.approx(0.0), ["r2"])


def test_a_step_that_clears_every_body_is_untouched():
    assert block(0.1, 0.0, 0.2, 0.0, 0.1, OTHER) == (0.2, 0.0, [])
    assert block(0.3, 0.3, 0.35, 0.3, 0.1, OTHER) == (0.35, 0.3, [])  # passing beside it
    assert block(0.25, 0.0, 0.35, 0.0, 0.1, {}) == (0.35, 0.0, [])


def test_a_glancing_step_slides_round_the_body_and_one_near_head_on_stalls():
    y0 = 0.2 * math.sin(math.pi / 3)
    x, y, met = block(0.4, y0, 0.41, y0, 0.1, OTHER)  # at contact, driving 60 deg off the line between the centres
    assert met == ["r2"]
    assert math.hypot(x - 0.5, y) >= 0.2 - 1e-9  # not into it
    assert 0.4 < x < 0.41 and y > y0  # round it, less what friction took
    x, y, met = block(0.3, 0.01, 0.31, 0.011, 0.1, OTHER)  # nearly head-on, already at contact
    assert met == ["r2"] and (x, y) == (pytest.approx(0.3, abs=3e-4), pytest.approx(0.01, abs=1e-4))  # to contact, no further across


def test_a_step_away_from_a_body_it_overlaps_is_free_and_none_goes_deeper():
    assert block(0.45, 0.0, 0.40, 0.0, 0.1, OTHER) == (0.40, 0.0, [])  # put down on it: it may back out
    x, y, met = block(0.40, 0.0, 0.45, 0.0, 0.1, OTHER)
    assert (x, y, met) == (pytest.approx(0.40), pytest.approx(0.0), ["r2"])  # not deeper, and not thrown out either


def test_a_robot_that_drives_into_another_stops_there_while_its_wheels_turn_on():
    free, held = (SimRobot(RobotConfig(), IDEAL, seed=1, body_radius=0.1) for _ in range(2))
    for _ in range(200):  # 2 s at 0.2 m/s: 0.4 m
        free.drive(0.2, 0.0, 0.01)
        held.step(*held.wheels(0.2, 0.0), 0.01, OTHER)
    assert free.state.x == pytest.approx(0.4)
    assert held.state.x == pytest.approx(0.3) and held.met == ["r2"] and held.state.v == pytest.approx(0.0)
    assert held.encoders() == free.encoders()  # the wheels slipped: the encoders counted the whole way
    held.step(*held.wheels(-0.2, 0.0), 0.01, OTHER)
    assert held.state.x == pytest.approx(0.298) and held.met == []  # backing away is free
    ghost = SimRobot(RobotConfig(), IDEAL, seed=1)  # no body of its own (body_radius 0): drives through
    for _ in range(200):
        ghost.step(*ghost.wheels(0.2, 0.0), 0.01, OTHER)
    assert ghost.state.x == pytest.approx(0.4)


def test_a_wall_holds_a_step_at_contact_and_lets_it_slide_along_as_friction_allows():
    assert block(0.85, 0.0, 0.95, 0.0, 0.1, {}, FIELD) == (pytest.approx(0.9), 0.0, ["wall x_max"])  # head-on: stops
    x, y, met = block(0.9, 0.0, 0.91, 0.02, 0.1, {}, FIELD)  # at contact, mostly along the wall
    assert met == ["wall x_max"] and x == pytest.approx(0.9) and y == pytest.approx(0.02 - 0.5 * 0.01)
    assert block(0.9, 0.0, 0.91, 0.001, 0.1, {}, FIELD)[:2] == (pytest.approx(0.9), 0.0)  # nearly head-on: stalls
    assert block(0.0, 0.0, 0.1, 0.1, 0.1, {}, FIELD) == (0.1, 0.1, [])  # clear of every wall
    assert block(0.9, 0.0, 0.8, 0.0, 0.1, {}, FIELD) == (0.8, 0.0, [])  # away from it: free


def test_a_corner_holds_both_ways_and_a_robot_outside_may_come_back_in_but_not_go_farther():
    x, y, met = block(0.9, 0.9, 0.95, 0.95, 0.1, {}, FIELD)
    assert (x, y) == (pytest.approx(0.9), pytest.approx(0.9)) and met == ["wall x_max", "wall y_max"]
    assert block(1.2, 0.0, 1.1, 0.0, 0.1, {}, FIELD) == (1.1, 0.0, [])  # put down outside: back in is free
    assert block(1.2, 0.0, 1.3, 0.0, 0.1, {}, FIELD)[:2] == (pytest.approx(1.2), 0.0)  # no farther out


def test_a_robot_driven_at_a_wall_stops_there_while_its_wheels_turn_on_and_one_without_a_footprint_drives_through():
    held = SimRobot(RobotConfig(), IDEAL, seed=1, x=0.5, body_radius=0.1, walls=FIELD)
    ghost = SimRobot(RobotConfig(), IDEAL, seed=1, x=0.5, walls=FIELD)  # no footprint (body_radius 0): no walls either
    for _ in range(300):  # 3 s at 0.2 m/s: 0.6 m, the last second against the wall
        held.drive(0.2, 0.0, 0.01)
        ghost.drive(0.2, 0.0, 0.01)
    assert held.state.x == pytest.approx(0.9) and held.met == ["wall x_max"] and held.state.v == pytest.approx(0.0)
    assert ghost.state.x == pytest.approx(1.1)  # through the edge
    assert held.encoders() == ghost.encoders()  # the wheels slipped: the encoders counted the whole way


CHASSIS = Chassis(0.16, 0.12)
TRACK = 0.1156  # [m] RobotConfig()'s track width


def rooms(x: float, y: float, theta: float, walls: Walls = FIELD) -> list[float]:
    """[m] how far inside each wall each corner of CHASSIS is (negative: past it)."""
    return [nx * (x + rx) + ny * (y + ry) + off for _, nx, ny, off in walls.faces for rx, ry in _corners(theta, CHASSIS)]


def drive(
    x: float, y: float, theta: float, left: float, right: float, steps: int, walls: Walls = FIELD
) -> tuple[float, float, float, float]:
    """A chassis whose wheels travel (left, right) [m] a step, `steps` times, inside `walls`: its pose, and its
    corners' deepest room over the run."""
    deepest = min(rooms(x, y, theta, walls))
    for _ in range(steps):
        a, b, _met = chassis_travel(x, y, theta, left, right, TRACK, CHASSIS, walls)
        x1, y1, th1 = arc(x, y, theta, (a + b) / 2.0, (b - a) / TRACK)
        x1, y1 = chassis_inside(x, y, theta, x1, y1, th1, CHASSIS, walls)
        x, y, theta = x1, y1, th1
        deepest = min(deepest, *rooms(x, y, theta, walls))
    return x, y, theta, deepest


@pytest.mark.parametrize("degrees", [10.0, -10.0, 30.0, -30.0])
def test_a_chassis_backed_into_a_wall_at_an_angle_squares_up_against_it(degrees):
    x, _, theta, deepest = drive(-0.7, 0.0, math.radians(degrees), -0.002, -0.002, 500)  # 1 m back toward x_min = -1
    assert theta == pytest.approx(0.0, abs=1e-9)  # its back flat against the wall
    assert x == pytest.approx(-1.0 + CHASSIS.length / 2)
    assert deepest > -1e-9  # no corner ever past the wall


def test_the_wheel_on_the_side_that_touched_is_held_and_the_other_drives_on():
    theta = math.radians(10.0)  # backing into x_min: the rear left corner (turned toward the wall) touches first
    x = -1.0 - min(rx for rx, _ in _corners(theta, CHASSIS))  # that corner at the wall
    left, right, met = chassis_travel(x, 0.0, theta, -0.002, -0.002, TRACK, CHASSIS, FIELD)
    assert met == ["wall x_min"]
    assert abs(left) < 0.15 * abs(right) and right < -0.8 * 0.002  # it turns about the corner


def test_a_chassis_flat_against_a_wall_is_held_and_drives_away_free():
    x = 1.0 - CHASSIS.length / 2  # its front on x_max
    assert chassis_travel(x, 0.0, 0.0, 0.002, 0.002, TRACK, CHASSIS, FIELD) == (pytest.approx(0.0), pytest.approx(0.0), ["wall x_max"])
    assert chassis_travel(x, 0.0, 0.0, -0.002, -0.002, TRACK, CHASSIS, FIELD) == (-0.002, -0.002, [])
    assert chassis_travel(0.0, 0.0, 0.0, 0.002, 0.002, TRACK, CHASSIS, FIELD) == (0.002, 0.002, [])  # far from every wall


def test_a_chassis_grazing_a_wall_turns_along_it():
    _, y, theta, deepest = drive(0.0, 0.9, math.radians(10.0), 0.002, 0.002, 300)  # toward y_max = 1 at 10 deg
    assert abs(theta) < 1e-3 and y == pytest.approx(1.0 - CHASSIS.width / 2, abs=1e-4)  # along it, its side on it
    assert deepest > -1e-9


def test_a_chassis_driven_into_the_fields_corner_stays_inside_both_walls():
    *_, deepest = drive(0.7, 0.7, math.radians(45.0), 0.002, 0.0025, 600)  # into x_max and y_max at once, turning
    assert deepest > -1e-9


def test_a_chassis_put_down_across_a_wall_may_come_back_in_but_goes_no_farther_out():
    start = min(rooms(1.0, 0.0, 0.3))  # its centre on x_max
    assert start < 0
    *_, deepest = drive(1.0, 0.0, 0.3, 0.002, 0.002, 100)  # driving out
    assert deepest >= start - 1e-9
    x, *_ = drive(1.0, 0.0, 0.3, -0.002, -0.002, 100)  # backing in
    assert x < 0.9


BOUND = st.tuples(st.floats(-1.0, 1.0), st.floats(-1.0, 1.0), st.floats(-1.0, 0.0))  # a u + b v >= low, (0, 0) keeps it


@settings(max_examples=300, deadline=None)
@given(st.lists(BOUND, min_size=1, max_size=5), st.floats(-2.0, 2.0), st.floats(-2.0, 2.0))
def test_the_nearest_travel_keeps_every_bound_and_no_point_that_keeps_them_is_nearer(bounds, p, q):
    u, v = _nearest(p, q, bounds)
    assert all(a * u + b * v >= low - 1e-9 for a, b, low in bounds)
    d = math.hypot(u - p, v - q)
    for i in range(-20, 21):  # a grid of points around (p, q)
        for j in range(-20, 21):
            gu, gv = p + i * 0.1, q + j * 0.1
            if all(a * gu + b * gv >= low for a, b, low in bounds):
                assert d <= math.hypot(gu - p, gv - q) + 1e-9


@settings(max_examples=200, deadline=None)
@given(
    st.floats(-0.95, 0.95),
    st.floats(-0.95, 0.95),
    st.floats(-math.pi, math.pi),
    st.lists(st.tuples(st.floats(-10.0, 10.0), st.floats(-10.0, 10.0)), min_size=1, max_size=30),
    st.lists(st.tuples(st.floats(-1.0, 1.0), st.floats(-1.0, 1.0)), max_size=2),
)
def test_a_chassis_among_walls_and_other_robots_never_goes_farther_past_a_wall(x, y, theta, commands, others):
    bot = SimRobot(RobotConfig(), IDEAL, 1, x, y, theta, body_radius=0.1, walls=FIELD, chassis=CHASSIS)
    bodies = {f"r{i}": Disc(ox, oy, 0.1) for i, (ox, oy) in enumerate(others, start=2)}

    def deepest(s) -> list[float]:
        """[m] per wall, how far inside it the chassis's deepest corner is."""
        return [min(nx * (s.x + rx) + ny * (s.y + ry) + off for rx, ry in _corners(s.theta, CHASSIS)) for _, nx, ny, off in FIELD.faces]

    for left, right in commands:
        for _ in range(20):
            before = deepest(bot.state)
            s = bot.step(left, right, 0.01, bodies)
            assert all(math.isfinite(v) for v in (s.x, s.y, s.theta, s.v, s.omega))
            # Inside a wall it stays inside; put down across one, it comes no farther out.
            assert all(now >= min(was, 0.0) - 1e-9 for now, was in zip(deepest(s), before, strict=True))
