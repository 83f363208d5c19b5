"""The planner: ways around the field's inflated obstacles, never into one, no shorter than the straight line."""

import math

import pytest
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st

from zenav.common.config import Field, Obstacle, Settings
from zenav.services.navigator.planner import NoPath, Planner, clearance, length

CLEAR = 0.12  # [m] footprint radius + margin
BOX = Obstacle(name="box", polygon=((0.55, -0.1), (0.75, -0.1), (0.75, 0.1), (0.55, 0.1)))
AREA = Field(x_min=-0.5, x_max=2.0, y_min=-0.6, y_max=0.6, obstacles=(BOX,))


def test_a_free_straight_way_is_the_goal_alone():
    assert Planner(AREA, CLEAR).plan((0.0, 0.4), (1.2, 0.4)) == [(1.2, 0.4)]


def test_a_goal_behind_a_box_is_reached_around_it_at_the_clearance():
    p = Planner(AREA, CLEAR)
    way = p.plan((0.0, 0.0), (1.2, 0.0))
    assert len(way) > 1 and way[-1] == (1.2, 0.0)
    gap = clearance(p.shapes, (0.0, 0.0), way)
    assert CLEAR - 1e-6 <= gap <= CLEAR * 1.03  # round the corners, no farther than the approximation
    shortest = 2 * math.hypot(0.55 - 0.0, 0.1 + CLEAR) + 0.2  # a lower bound: straight to the inflated corners
    assert math.dist((0, 0), (1.2, 0)) < length((0.0, 0.0), way) <= 1.1 * shortest


def test_a_walled_in_goal_has_no_path():
    walls = tuple(
        Obstacle(polygon=pts)
        for pts in (
            ((0.9, -0.6), (1.0, -0.6), (1.0, 0.6), (0.9, 0.6)),  # a wall across the whole field
        )
    )
    with pytest.raises(NoPath, match="no way"):
        Planner(Field(x_min=-0.5, x_max=2.0, y_min=-0.6, y_max=0.6, obstacles=walls), CLEAR).plan((0.0, 0.0), (1.5, 0.0))


def test_a_start_inside_the_inflation_steps_out_the_shortest_way():
    p = Planner(AREA, CLEAR)
    start = (0.55 - 0.05, 0.0)  # 5 cm from the box's face: within the clearance
    way = p.plan(start, (0.0, 0.0))
    assert way == [(0.0, 0.0)]  # the way back is free: straight
    way = p.plan(start, (1.2, 0.0))
    assert way[0][0] < start[0] and abs(way[0][1]) < 1e-6  # first straight back out, away from the face


@pytest.mark.parametrize(("name", "goal"), [("table", (1.2, 1.05)), ("table", (1.0, 0.0)), ("arena", (3.0, 3.0)), ("arena", (1.1, 0.4))])
def test_the_shipped_fields_plan_within_their_bounds(name, goal):
    area = Settings.load(None, field={"file": name}).field
    p = Planner(area, CLEAR)
    assert min(s.clearance(*goal) for s in p.shapes) >= CLEAR
    way = p.plan((0.0, 0.0), goal)
    assert len(way) > 1  # each is behind something
    assert clearance(p.shapes, (0.0, 0.0), way) >= CLEAR - 1e-6
    for x, y in way[:-1]:
        assert area.x_min + CLEAR - 1e-9 <= x <= area.x_max - CLEAR + 1e-9
        assert area.y_min + CLEAR - 1e-9 <= y <= area.y_max - CLEAR + 1e-9


coord = st.floats(0.0, 2.0)


@st.composite
def fields(draw):
    obstacles = []
    for _ in range(draw(st.integers(1, 6))):
        x, y, w, h = draw(coord), draw(coord), draw(st.floats(0.05, 0.4)), draw(st.floats(0.05, 0.4))
        if draw(st.booleans()):
            obstacles.append(Obstacle(circle=(x, y, w / 2)))
        else:
            obstacles.append(Obstacle(polygon=((x, y), (x + w, y), (x + w, y + h), (x, y + h))))
    try:
        return Field(x_min=-0.3, x_max=2.5, y_min=-0.3, y_max=2.5, obstacles=tuple(obstacles))
    except Exception:
        assume(False)
        raise


SQUARE = ((0.0, 0.0), (0.25, 0.0), (0.25, 0.25), (0.0, 0.25))
BOX = Field(x_min=-0.3, x_max=2.5, y_min=-0.3, y_max=2.5, obstacles=(Obstacle(polygon=SQUARE),))
NEAR_BOX = (0.0, 0.3715106341169761)  # clear of the box by CLEAR, inside its inflated outline's corner: stepped out of


@settings(max_examples=60, deadline=None)
@given(fields(), st.tuples(coord, coord), st.tuples(coord, coord))
@example(BOX, (0.0, 1.0), NEAR_BOX)  # the way still ends on the goal, not where its step out ends
@example(BOX, NEAR_BOX, NEAR_BOX)  # a goal where the robot is: the goal, not an empty way
@example(BOX, (0.0, 1.0), (5e-324, 1.0))  # a leg all but parallel to a side
def test_a_plan_never_enters_an_inflated_obstacle_and_is_no_shorter_than_the_straight_line(area, start, goal):
    p = Planner(area, CLEAR)
    assume(all(s.clearance(*start) >= CLEAR and s.clearance(*goal) >= CLEAR for s in p.shapes))
    try:
        way = p.plan(start, goal)
    except NoPath:
        return
    assert way[-1] == goal
    assert length(start, way) >= math.dist(start, goal) - 1e-9
    assert clearance(p.shapes, start, way) >= CLEAR - 1e-6
