"""traffic.py: who drives round whom, keeping right, and clear of where the robot with the right of way is going;
who slows to let a crossing robot pass; who steps aside for a robot on its goal."""

import math

from zenav.bench import crossing
from zenav.common.config import Field, Obstacle
from zenav.common.contract import GoalResult, State
from zenav.services.navigator.controllers import PoseSample, Wheelbase
from zenav.services.navigator.goals import Goal
from zenav.services.navigator.params import Params
from zenav.services.navigator.planner import Planner
from zenav.services.navigator.traffic import Decision, Other, Traffic
from zenav.services.navigator.traffic_machine import TrafficMachine

AREA = Field(x_min=0.0, x_max=3.0, y_min=0.0, y_max=3.0)
CLEAR = 0.1 + 0.05  # [m] footprint and margin: how far the detour's points keep from the edges


def test_two_robots_head_on_both_keep_right():
    r1, r2 = Traffic("r1", 0.1, 0.05), Traffic("r2", 0.1, 0.05)
    d1 = r1.decide((0.0, 0.0), [(2.0, 0.0)], [Other("r2", 0.8, 0.0, 0.1, -0.2, 0.0)])
    d2 = r2.decide((0.8, 0.0), [(-1.2, 0.0)], [Other("r1", 0.0, 0.0, 0.1, 0.2, 0.0)])
    assert d1.detour is not None and d2.detour is not None
    assert d1.detour[0][1] < 0.0  # r1 heads +x: its right is -y
    assert d2.detour[0][1] > 0.0  # r2 heads -x: its right is +y


def test_only_the_robot_without_the_right_of_way_clears_the_others_course():
    across = Other("r1", 0.5, -0.4, 0.1, 0.0, 0.3)  # crossing the way ahead, 0.4 m off it, coming closer
    d = Traffic("r2", 0.1, 0.05).decide((0.0, 0.0), [(1.0, 0.0)], [across])
    assert d.detour is not None or d.scale < 1.0  # round it, or slower to let it pass
    mine = Other("r3", 0.5, -0.4, 0.1, 0.0, 0.3)
    d = Traffic("r2", 0.1, 0.05).decide((0.0, 0.0), [(1.0, 0.0)], [mine])
    assert d.driving and d.detour is None and d.scale == 1.0  # r2 has the right of way: r3 is seen where it is


def test_a_robot_on_the_goal_is_waited_for():
    d = Traffic("r2", 0.1, 0.05).decide((0.5, 0.0), [(1.0, 0.0)], [Other("r1", 1.0, 0.05, 0.1)])
    assert d.wait == "r1" and "leave the goal" in d.why


def test_two_robots_swapping_places_arrive_without_contact():
    res = crossing.measure("2 swapping", 1, seed=1)
    assert res.succeeded == 1 and res.contact_runs == 0 and res.least > 0.05


def test_a_detour_near_the_edge_goes_round_on_the_side_that_has_room_and_stays_inside_the_field():
    edges = Planner(AREA, CLEAR)
    # Heading +x along y = 0.25, right next to the lower edge: keeping right (-y) would leave the field.
    d = Traffic("r2", 0.1, 0.05, edges).decide((0.5, 0.25), [(2.0, 0.25)], [Other("r1", 1.0, 0.25, 0.1)])
    assert d.detour is not None
    assert all(p[1] > 0.25 for p in d.detour[:-1])  # round on the left, where there is room
    assert all(CLEAR - 1e-9 <= x <= 3.0 - CLEAR and CLEAR - 1e-9 <= y <= 3.0 - CLEAR for x, y in d.detour)


def test_a_detour_round_a_robot_keeps_clear_of_the_fields_obstacles_near_it():
    area = Field(x_min=0.0, x_max=3.0, y_min=0.0, y_max=3.0, obstacles=(Obstacle(name="post", circle=(1.0, 1.25, 0.1)),))
    field = Planner(area, CLEAR)
    d = Traffic("r2", 0.1, 0.05, field).decide((0.3, 1.5), [(2.0, 1.5)], [Other("r1", 1.0, 1.5, 0.1)])
    assert d.detour is not None
    legs = list(zip([(0.3, 1.5), *d.detour[:-1]], d.detour))
    assert all(field.free(a, b) for a, b in legs)  # round the robot and clear of the post beside it


def test_a_robot_crossing_the_way_with_the_right_of_way_is_let_pass_by_slowing():
    # r1 comes up from below at 0.2 m/s and crosses the way 0.5 m ahead about when r2 would get there.
    d = Traffic("r2", 0.1, 0.05).decide((0.0, 0.0), [(2.0, 0.0)], [Other("r1", 0.5, -0.4, 0.1, 0.0, 0.2)], speed=0.2)
    assert d.driving and d.detour is None
    assert 0.0 < d.scale < 1.0 and d.why == "slowing for robot r1 to pass"


def test_a_crossing_robot_that_passes_well_ahead_slows_nothing():
    d = Traffic("r2", 0.1, 0.05).decide((0.0, 0.0), [(2.0, 0.0)], [Other("r1", 0.9, -0.2, 0.1, 0.0, 0.2)], speed=0.2)
    assert d.driving and d.detour is None and d.scale == 1.0  # it is past the way before r2 gets there


def test_the_robot_without_the_right_of_way_steps_aside_for_one_standing_on_its_goal():
    # Each stands on the other's goal, 0.5 m apart: r2 steps off the line between them; r1 waits for it.
    r1, r2 = Other("r1", 1.0, 1.0, 0.1), Other("r2", 1.5, 1.0, 0.1)
    d2 = Traffic("r2", 0.1, 0.05).decide((1.5, 1.0), [(1.0, 1.0)], [r1], aside=True)
    assert d2.aside and d2.detour is not None and d2.detour[-1] == (1.0, 1.0)
    step = d2.detour[0]
    assert abs(step[0] - 1.5) < 1e-9 and step[1] > 1.0 + 0.28  # facing -x its right is +y, off the line by reach
    assert Traffic("r2", 0.1, 0.05).decide((1.5, 1.0), [(1.0, 1.0)], [r1], aside=False).wait == "r1"  # once only
    assert Traffic("r1", 0.1, 0.05).decide((1.0, 1.0), [(1.5, 1.0)], [r2], aside=True).wait == "r2"  # r1 has the right of way


def test_two_robots_on_each_others_goals_swap_without_waiting_for_robot_wait():
    a, b = (1.0, 1.0), (1.5, 1.0)
    robots = [("r1", a, b, 0.0), ("r2", b, a, math.pi)]
    runs, least, contacts = crossing.simulate(robots, 7, Params(robot_wait=20.0))
    assert [r.done for r in runs] == [GoalResult.SUCCEEDED, GoalResult.SUCCEEDED]
    assert contacts == 0 and least > 0.0
    assert max(r.t_end for r in runs) < 20.0  # simulated time: resolved long before robot_wait would end a goal
    assert runs[1].machine.counts["robot_asides"] == 1


def test_four_robots_crossing_the_centre_arrive_without_contact():
    res = crossing.measure("4 crossing the centre", 1, seed=1)
    assert res.succeeded == 1 and res.contact_runs == 0 and res.least > 0.0


def test_a_detour_replanned_rejoins_the_goals_own_way_not_the_earlier_detour():
    way = [(0.5, -0.5), (2.0, 0.0)]  # a detour's corner, then the goal's own point
    standing = [Other("r3", 0.2, -0.1, 0.1)]  # on the detour's first leg; its corner is clear of it
    assert Traffic("r2", 0.1, 0.05).decide((0.0, 0.0), way, standing).rejoin == 0
    d = Traffic("r2", 0.1, 0.05).decide((0.0, 0.0), way, standing, base=1)
    assert d.detour is not None and d.rejoin == 1 and d.detour[-1] == (2.0, 0.0)


def test_the_goal_machine_replaces_a_blocked_detour_whole():
    params = Params()
    wheels = Wheelbase(0.15, 0.03, 10.0)
    machine = TrafficMachine(params, wheels, AREA, traffic=Traffic("r2", 0.1, 0.05, Planner(AREA, 0.15)))
    machine.on_pose(PoseSample(0.0, 0.5, 1.5, 0.0, 0.0, 0.0, 0.0, 0.0))
    machine.start(Goal(State.MOVING_TO_POINT, points=((2.5, 1.5),), speed=0.2, tolerance=params.tolerance), 0.0)
    machine.drive(PoseSample(0.0, 0.5, 1.5, 0.0, 0.0, 0.0, 0.0, 0.0), [Other("r3", 1.0, 1.5, 0.1)])
    run = machine._run
    assert run is not None and machine.counts["robot_detours"] == 1
    first = run.goal.points[:-1]  # the detour's corners
    assert len(first) == 2 and first[1][0] < 1.1  # round r3 on the right: its second corner beside r3
    blocker = Other("r3", 0.62, 1.2, 0.1)  # now on the detour's first corner; its second corner is clear of it
    machine.drive(PoseSample(0.5, 0.5, 1.5, 0.0, 0.0, 0.0, 0.0, 0.0), [blocker])
    assert machine.counts["robot_detours"] == 2
    points = run.goal.points[run.index :]
    assert points[-1] == (2.5, 1.5) and not set(first) & set(points)  # no corner of the blocked detour is kept


def test_a_robot_that_tells_its_way_is_foreseen_along_it_not_along_its_velocity():
    told = Other("r1", 0.0, 0.0, 0.1, 0.2, 0.0, way=((0.3, 0.0), (0.3, 1.0)))  # heads +x, turns left at 0.3
    assert told.at(0.0) == (0.0, 0.0)
    x, y = told.at(2.5)  # 0.5 m along its way: round the corner
    assert math.isclose(x, 0.3) and math.isclose(y, 0.2)
    assert told.at(100.0) == (0.3, 1.0)  # standing at its way's end
    x, y = Other("r1", 0.0, 0.0, 0.1, 0.2, 0.0).at(2.5)  # not told: along its velocity
    assert math.isclose(x, 0.5) and y == 0.0


def test_a_robot_whose_told_way_turns_off_before_the_crossing_is_not_given_way_to():
    # r1 comes up towards r2's way at 0.2 m/s; along its velocity it crosses it 0.5 m ahead just when r2 gets there.
    coming = Other("r1", 0.5, -0.4, 0.1, 0.0, 0.2)
    assert Traffic("r2", 0.1, 0.05).decide((0.0, 0.0), [(2.0, 0.0)], [coming], speed=0.2) != Decision()
    # It tells its way: it turns back down 0.1 m on, never reaching r2's way.
    turning = Other("r1", 0.5, -0.4, 0.1, 0.0, 0.2, way=((0.5, -0.3), (1.5, -1.0)))
    assert Traffic("r2", 0.1, 0.05).decide((0.0, 0.0), [(2.0, 0.0)], [turning], speed=0.2) == Decision()


def test_a_crossing_robot_is_passed_in_a_lane_right_of_the_way_at_full_speed_before_slowing():
    # r1 crosses r2's way from r2's right 0.75 m ahead, about when r2 gets there: r2 passes behind it, keeping right of
    # its way (heading +x its right is -y), at full speed.
    d = Traffic("r2", 0.1, 0.05).decide((0.0, 0.0), [(2.0, 0.0)], [Other("r1", 0.75, -0.45, 0.1, 0.0, 0.2)], speed=0.2)
    assert d.detour is not None and d.scale == 1.0 and d.rejoin == 0
    corner, end = d.detour
    assert end == (2.0, 0.0) and math.isclose(corner[0], 1.0) and -0.41 < corner[1] < 0.0
