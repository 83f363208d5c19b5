"""The field model: obstacles checked with clear errors, clearance, inflation, and the [field] config and file."""

import json
import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from zenav.common.config import ConfigError, Settings
from zenav.common.field import FieldError, Shape, circle_shape, contains, inflate, polygon_shape

SQUARE = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]


def test_a_polygon_is_made_counter_clockwise_and_measures_clearance():
    s = polygon_shape("box", SQUARE[::-1])
    assert s.polygon[1][0] > s.polygon[0][0] or s.polygon[1][1] > s.polygon[0][1]  # counter-clockwise now
    assert s.clearance(0.5, 0.5) == pytest.approx(-0.5)
    assert s.clearance(2.0, 0.5) == pytest.approx(1.0)
    assert s.clearance(2.0, 2.0) == pytest.approx(math.sqrt(2.0))
    assert s.segment_clearance((-1.0, 0.5), (2.0, 0.5)) == 0.0  # through it
    assert s.segment_clearance((-1.0, 1.5), (2.0, 1.5)) == pytest.approx(0.5)


@pytest.mark.parametrize(
    ("points", "why"),
    [
        ([[0, 0], [1, 0]], "at least 3 corners"),
        ([[0, 0], [1, 0], [2, 0]], "no area"),
        ([[0, 0], [1, 0], [1, 0], [0, 1]], "same point"),
        ([[0, 0], [1, 1], [1, 0], [0, 1]], "self-intersecting"),
        ([[0, 0], [2, 0], [2, 2], [1, 0], [0, 2]], "self-intersecting"),  # a corner on another edge
    ],
)
def test_bad_polygons_are_refused_naming_why(points, why):
    with pytest.raises(FieldError, match=why):
        polygon_shape("obstacles[0]", points)


def test_a_circle_needs_a_positive_radius():
    assert circle_shape("c", [1, 2, 0.5]).clearance(1.0, 3.0) == pytest.approx(0.5)
    with pytest.raises(FieldError, match="radius"):
        circle_shape("c", [1, 2, 0])


def test_config_obstacles_are_checked_against_the_field_and_each_other():
    area = Settings.load(None, field={"obstacles": [{"name": "box", "polygon": SQUARE}, {"circle": [2.0, 2.0, 0.1]}]}).field
    assert [s.name for s in area.shapes()] == ["obstacles[0] 'box'", "obstacles[1]"]
    with pytest.raises(ConfigError, match=r"obstacles\[0\] 'far': lies outside the field"):
        Settings.load(None, field={"obstacles": [{"name": "far", "circle": [10.0, 0.0, 0.5]}]})
    with pytest.raises(ConfigError, match="duplicate"):
        Settings.load(None, field={"obstacles": [{"polygon": SQUARE}, {"polygon": SQUARE[1:] + SQUARE[:1]}]})
    with pytest.raises(ConfigError, match="self-intersecting"):
        Settings.load(None, field={"obstacles": [{"polygon": [[0, 0], [1, 1], [1, 0], [0, 1]]}]})
    with pytest.raises(ConfigError, match="either a polygon"):
        Settings.load(None, field={"obstacles": [{"polygon": SQUARE, "circle": [0, 0, 1]}]})
    with pytest.raises(ConfigError, match="id 3 is given twice"):
        Settings.load(None, field={"tags": [{"id": 3, "x": 0, "y": 0}, {"id": 3, "x": 1, "y": 0}]})


@pytest.mark.parametrize("name", ["table", "arena"])
def test_the_shipped_field_files_load(name):
    area = Settings.load(None, field={"file": name}).field
    assert len(area.shapes()) >= 5 and len(area.tags) >= 4
    assert area.x_min < 0.0 < area.x_max  # the robot's default start (0, 0) is on it


def test_a_field_file_in_json_beside_the_config_and_its_conflicts(tmp_path):
    (tmp_path / "f.json").write_text(json.dumps({"x_min": 0, "x_max": 2, "y_min": 0, "y_max": 1, "obstacles": [{"circle": [1, 0.5, 0.1]}]}))
    config = tmp_path / "zenav.toml"
    config.write_text('[field]\nfile = "f.json"\n')
    area = Settings.load(str(config)).field
    assert (area.x_max, len(area.obstacles)) == (2.0, 1)
    config.write_text('[field]\nfile = "f.json"\nx_max = 3.0\n')
    with pytest.raises(ConfigError, match="`x_max` is set both here and in its file"):
        Settings.load(str(config))
    (tmp_path / "f.json").write_text(json.dumps({"walls": []}))
    config.write_text('[field]\nfile = "f.json"\n')
    with pytest.raises(ConfigError, match="unknown key `walls`"):
        Settings.load(str(config))
    config.write_text('[field]\nfile = "missing.toml"\n')
    with pytest.raises(ConfigError, match="missing.toml"):
        Settings.load(str(config))


def test_a_tag_pose_as_a_wpilib_quaternion():
    area = Settings.load(None, field={"tags": [{"id": 1, "x": 1.0, "y": 2.0, "yaw": math.pi}]}).field
    w, x, y, z = area.tags[0].quaternion
    assert (abs(w), x, y, z) == pytest.approx((0.0, 0.0, 0.0, 1.0))


corner = st.tuples(st.floats(-1.0, 1.0), st.floats(-1.0, 1.0))


@settings(max_examples=60, deadline=None)
@given(
    st.lists(corner, min_size=3, max_size=7),
    st.floats(0.01, 0.3),
    st.tuples(st.floats(-1.5, 1.5), st.floats(-1.5, 1.5)),
)
def test_inflation_holds_every_point_within_the_radius(points, radius, probe):
    try:
        shape = polygon_shape("p", points)
    except FieldError:
        return
    pieces = inflate(shape, radius)
    if shape.clearance(*probe) < radius:
        assert any(contains(p, *probe) or _on_edge(p, probe) for p in pieces)


def _on_edge(poly, p) -> bool:
    return Shape("x", poly).clearance(*p) > -1e-9 and Shape("x", poly).clearance(*p) < 1e-9
