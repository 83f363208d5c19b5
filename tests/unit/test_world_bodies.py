"""Robots' bodies as discs: a step into another body or a wall stops at contact, slides round it, and never pushes it."""

import math

import pytest

from zenav.common.config import Robot
from zenav.world.bodies import Disc, Walls, block
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
    free, held = (SimRobot(Robot(), IDEAL, seed=1, body_radius=0.1) for _ in range(2))
    for _ in range(200):  # 2 s at 0.2 m/s: 0.4 m
        free.drive(0.2, 0.0, 0.01)
        held.step(*held.wheels(0.2, 0.0), 0.01, OTHER)
    assert free.state.x == pytest.approx(0.4)
    assert held.state.x == pytest.approx(0.3) and held.met == ["r2"] and held.state.v == pytest.approx(0.0)
    assert held.encoders() == free.encoders()  # the wheels slipped: the encoders counted the whole way
    held.step(*held.wheels(-0.2, 0.0), 0.01, OTHER)
    assert held.state.x == pytest.approx(0.298) and held.met == []  # backing away is free
    ghost = SimRobot(Robot(), IDEAL, seed=1)  # no body of its own (body_radius 0): drives through
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
    held = SimRobot(Robot(), IDEAL, seed=1, x=0.5, body_radius=0.1, walls=FIELD)
    ghost = SimRobot(Robot(), IDEAL, seed=1, x=0.5, walls=FIELD)  # no footprint (body_radius 0): no walls either
    for _ in range(300):  # 3 s at 0.2 m/s: 0.6 m, the last second against the wall
        held.drive(0.2, 0.0, 0.01)
        ghost.drive(0.2, 0.0, 0.01)
    assert held.state.x == pytest.approx(0.9) and held.met == ["wall x_max"] and held.state.v == pytest.approx(0.0)
    assert ghost.state.x == pytest.approx(1.1)  # through the edge
    assert held.encoders() == ghost.encoders()  # the wheels slipped: the encoders counted the whole way
