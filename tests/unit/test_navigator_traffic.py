"""traffic.py: who drives round whom, keeping right, and clear of where the robot with the right of way is going."""

from zenav.bench import crossing
from zenav.services.navigator.traffic import Other, Traffic


def test_two_robots_head_on_both_keep_right():
    r1, r2 = Traffic("r1", 0.1, 0.05), Traffic("r2", 0.1, 0.05)
    d1 = r1.decide((0.0, 0.0), [(2.0, 0.0)], [Other("r2", 0.8, 0.0, 0.1, -0.2, 0.0)])
    d2 = r2.decide((0.8, 0.0), [(-1.2, 0.0)], [Other("r1", 0.0, 0.0, 0.1, 0.2, 0.0)])
    assert d1.detour is not None and d2.detour is not None
    assert d1.detour[0][1] < 0.0  # r1 heads +x: its right is -y
    assert d2.detour[0][1] > 0.0  # r2 heads -x: its right is +y


def test_only_the_robot_without_the_right_of_way_clears_the_others_course():
    across = Other("r1", 0.5, -0.6, 0.1, 0.0, 0.3)  # crossing the way ahead, 0.6 m off it, coming closer
    assert Traffic("r2", 0.1, 0.05).decide((0.0, 0.0), [(1.0, 0.0)], [across]).detour is not None
    mine = Other("r3", 0.5, -0.6, 0.1, 0.0, 0.3)
    assert Traffic("r2", 0.1, 0.05).decide((0.0, 0.0), [(1.0, 0.0)], [mine]).driving  # r2 has the right of way: where r3 is


def test_a_robot_on_the_goal_is_waited_for():
    d = Traffic("r2", 0.1, 0.05).decide((0.5, 0.0), [(1.0, 0.0)], [Other("r1", 1.0, 0.05, 0.1)])
    assert d.wait == "r1" and "leave the goal" in d.why


def test_two_robots_swapping_places_arrive_without_contact():
    res = crossing.measure("2 swapping", 1, seed=1)
    assert res.succeeded == 1 and res.contact_runs == 0 and res.least > 0.05
