"""Fixtures of the unit tests."""

import pytest

from tests.support.navigator import World


@pytest.fixture
def world():
    """The navigator rig as the robot library's bus, its robot's first pose published."""
    w = World()
    w.pose()
    yield w
    w.nav.close()
