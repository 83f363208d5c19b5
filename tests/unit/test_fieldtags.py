"""The field's fixed tags in 3D: WPILib layouts read as [field] tags, each tag's corners, bad layouts refused at start."""

import json
import math

import numpy as np
import pytest

from zenav.common import fieldtags, geometry
from zenav.common.config import ConfigError, Settings


def layout(*tags):
    """A WPILib AprilTagFieldLayout with tags (id, x, y, z, quaternion W, X, Y, Z)."""
    return {
        "tags": [
            {"ID": i, "pose": {"translation": {"x": x, "y": y, "z": z}, "rotation": {"quaternion": {"W": w, "X": qx, "Y": qy, "Z": qz}}}}
            for i, x, y, z, (w, qx, qy, qz) in tags
        ],
        "field": {"length": 3.6, "width": 3.6},
    }


def test_euler_inverts_the_quaternion_of_every_rotation():
    for yaw, pitch, roll in [(0.3, -0.4, 1.1), (-2.9, 1.2, -0.2), (math.pi, 0.0, 0.0), (0.0, -1.5707963, 0.0)]:
        got = fieldtags.euler(*geometry.quaternion(yaw, pitch, roll))
        assert np.allclose(fieldtags.rotation(*got), fieldtags.rotation(yaw, pitch, roll), atol=1e-6)


def test_a_wall_tag_reads_left_to_right_facing_it():
    # A tag on the east wall facing west (-x): a viewer facing it looks along +x, its right is -y.
    c = fieldtags.corners(0.2, 3.0, 1.0, 0.5, math.pi)
    assert np.allclose(c, [[3.0, 1.1, 0.6], [3.0, 0.9, 0.6], [3.0, 0.9, 0.4], [3.0, 1.1, 0.4]])
    # A tag flat on the floor facing up (pitch -pi/2): its top towards -x, its right towards +y seen from above.
    up = fieldtags.corners(0.2, 0.0, 0.0, 0.0, 0.0, -math.pi / 2)
    assert np.allclose(up[:, 2], 0.0) and np.allclose(up[:2], [[-0.1, -0.1, 0.0], [-0.1, 0.1, 0.0]])


def test_a_wpilib_layout_joins_the_field_tags(tmp_path):
    (tmp_path / "layout.json").write_text(
        json.dumps(layout((7, 3.2, 1.4, 0.3, (0.0, 0.0, 0.0, 1.0)), (8, 0.0, 1.0, 0.5, (1.0, 0.0, 0.0, 0.0))))
    )
    config = tmp_path / "zenav.toml"
    config.write_text('[field]\nx_min = -1\nx_max = 4\ntags_file = "layout.json"\ntag_size = 0.1651\ntags = [{ id = 1, x = 0, y = 0 }]\n')
    tags = {t.id: t for t in Settings.load(str(config)).field.tags}
    assert sorted(tags) == [1, 7, 8]
    assert (tags[7].size, tags[7].x, tags[7].z) == (0.1651, 3.2, 0.3)
    assert tags[7].yaw == pytest.approx(math.pi) and tags[8].yaw == pytest.approx(0.0)
    assert abs(tags[7].quaternion[3]) == pytest.approx(1.0)  # WPILib's Z=1: facing -x


@pytest.mark.parametrize(
    ("content", "extra", "error"),
    [
        (layout((1, 0, 0, 0, (1, 0, 0, 0))), "", "gives no tag size: set \\[field\\] tag_size"),
        (layout((1, 0, 0, 0, (1, 0, 0, 0)), (1, 1, 0, 0, (1, 0, 0, 0))), "tag_size = 0.1\n", "id 1 is given twice"),
        (layout((1, 0, 0, 0, (0, 0, 0, 0))), "tag_size = 0.1\n", "tags\\[0\\]: .*not a rotation"),
        ({"tags": [{"ID": 1, "pose": {"translation": {"x": 0}}}]}, "tag_size = 0.1\n", "tags\\[0\\]: missing 'rotation'"),
        ({"fields": []}, "tag_size = 0.1\n", "an object with a `tags` list"),
        ("not json", "tag_size = 0.1\n", "tags_file layout.json: Expecting value"),
    ],
)
def test_a_bad_layout_is_refused_at_start_saying_why(tmp_path, content, extra, error):
    (tmp_path / "layout.json").write_text(content if isinstance(content, str) else json.dumps(content))
    config = tmp_path / "zenav.toml"
    config.write_text(f'[field]\ntags_file = "layout.json"\n{extra}')
    with pytest.raises(ConfigError, match=error):
        Settings.load(str(config))


def test_a_missing_layout_file_is_named(tmp_path):
    with pytest.raises(ConfigError, match="tags_file .*nowhere.json"):
        Settings.load(None, field={"tags_file": str(tmp_path / "nowhere.json"), "tag_size": 0.1})


def test_a_tag_no_camera_on_the_field_can_see_is_refused_at_start():
    with pytest.raises(ConfigError, match=r"tag 5 at \(3, 1\) faces out of the field .*yaw off by pi"):
        Settings.load(None, field={"tags": [{"id": 5, "x": 3.0, "y": 1.0, "z": 0.3, "yaw": 0.0}]})
    with pytest.raises(ConfigError, match=r"tag 6 at \(16.5, 4\) lies outside the field \(x -1..3, y -1..3\)"):
        Settings.load(None, field={"tags": [{"id": 6, "x": 16.5, "y": 4.0, "z": 0.3, "yaw": 3.14}]})
    floor = Settings.load(None, field={"tags": [{"id": 7, "x": 1.0, "y": 1.0, "pitch": -math.pi / 2}]}).field
    assert [t.id for t in floor.tags] == [7]  # flat on the floor, facing up: seen from above


def test_the_default_tags_belong_to_the_default_field():
    assert len(Settings.load(None).field.tags) == 12
    assert Settings.load(None, field={"x_min": 0.0, "x_max": 2.0}).field.tags == ()
