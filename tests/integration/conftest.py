"""Fixtures of the integration tests."""

import pytest

from zenav.common.bus import ZenohBus


@pytest.fixture
def publisher(router):
    """A bus on the test's router to publish from."""
    bus = ZenohBus.open(router)
    yield bus
    bus.close()
