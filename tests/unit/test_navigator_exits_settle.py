"""The settle table's quick run: every move type reported, in its columns."""

from zenav.bench import settle


def test_quick_table_has_a_row_per_move_with_every_column():
    text = settle.table(trials=1)
    rows = [line for line in text.splitlines() if line.startswith("| ") and not line.startswith("| move")]
    assert [r.split(" | ")[0][2:] for r in rows] == [mv.name for mv in settle.moves(settle.Params())]
    assert all(r.count(" | ") == 6 and ("1/1" in r or "0/1" in r) for r in rows)
    assert "within_tolerance" in text and "5 cm waypoints" in text
