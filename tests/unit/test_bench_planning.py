"""The bench's planning section, small: every reachable pair found, clear, near the shortest; a driven goal arrives."""

from zenav.bench import planning


def test_the_planner_figures_of_one_layout():
    r = planning.measure("random20", 8, seed=3)
    assert r.obstacles == 20 and r.pairs == 8 and r.failed == 0
    assert min(r.clearances) >= planning.RADIUS + planning.MARGIN - 1e-6
    assert 0.999 <= min(r.ratios) and max(r.ratios) <= 1.1


def test_a_blocked_goal_driven_on_the_world_model_arrives_without_contact():
    d = planning.driven("table", 1, seed=1)
    assert d.goals == 1 and d.succeeded == 1 and d.contacts == 0 and d.clearances[0] > planning.RADIUS
    assert "| table | 1 | 1 | 0 |" in "\n".join(planning.tables([], [d]))
