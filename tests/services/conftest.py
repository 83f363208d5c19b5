"""Fixtures of the service tests."""

import pytest

from tests.support.navigator import NavigatorRig


@pytest.fixture
def rig():
    """The navigator rig, its robot's first pose published."""
    r = NavigatorRig()
    r.pose()
    yield r
    r.nav.close()
