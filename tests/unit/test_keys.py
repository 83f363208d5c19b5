"""The contract's keys: built from a robot id and a suffix, and split back."""

from __future__ import annotations

import pytest

from zenav.common import keys


@pytest.mark.parametrize(
    "key, where",
    [
        ("zenav/r-2/vps/pose", ("r-2", "vps/pose")),
        ("zenav/field/camera/frame", ("field", "camera/frame")),
        ("zenav/r1/diag/sim", ("r1", "diag/sim")),
        ("other/r1/odom", None),
        ("zenav/r1", None),
    ],
)
def test_split_is_the_inverse_of_key(key, where):
    assert keys.split(key) == where
    if where is not None and where[0] != keys.FIELD:
        assert keys.key(*where) == key


def test_in_loop_names_only_a_robots_loop_topics():
    assert keys.in_loop("zenav/r1/cmd_vel")
    assert keys.in_loop("zenav/r1/sensors/encoders")
    assert not keys.in_loop("zenav/r1/nav/state")
    assert not keys.in_loop("zenav/field/camera/frame")
    assert not keys.in_loop("other/r1/cmd_vel")
