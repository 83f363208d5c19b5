"""The other robots as last heard: the newest report each, this robot's own never, the silent forgotten."""

from zenav.common.others import Others


def test_keeps_each_robots_newest_report_but_not_its_own():
    others: Others[str] = Others("r1", kept=0.5)
    others.heard("r2", 1.0, "old")
    others.heard("r1", 1.0, "mine")
    others.heard("r2", 1.1, "new")
    others.heard("r3", 1.2, "third")
    assert others.at(1.2) == {"r2": "new", "r3": "third"}


def test_forgets_a_robot_not_heard_within_kept_and_takes_it_back_when_heard_again():
    others: Others[int] = Others("r1", kept=0.5)
    others.heard("r2", 1.0, 1)
    others.heard("r3", 1.4, 3)
    assert others.at(1.5) == {"r2": 1, "r3": 3}  # exactly kept: still there
    assert others.at(1.6) == {"r3": 3}
    assert others.at(1.0) == {"r3": 3}  # forgotten is gone, whatever the clock says next
    others.heard("r2", 2.0, 2)
    assert others.at(2.0) == {"r2": 2}
