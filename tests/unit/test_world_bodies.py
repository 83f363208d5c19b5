"""Robots' bodies as discs: a step into another body stops at contact, slides round it, and never pushes it."""

import math

import pytest

from zenav.common.config import Robot
from zenav.world.bodies import Disc, block
from zenav.world.sim import SimRobot

from .test_world_sim import IDEAL

OTHER = {"r2": Disc(0.5, 0.0, 0.1)}


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
