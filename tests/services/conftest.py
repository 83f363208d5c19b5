"""Fixtures of the service tests."""

import pytest

from tests.support.navigator import Rig


@pytest.fixture
def rig():
    """The navigator rig, its robot's first pose published."""
    r = Rig()
    r.pose()
    yield r
    r.nav.close()
