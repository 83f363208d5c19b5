"""Fixtures shared by the test suites: a real router, an in-process stack, a client."""
from __future__ import annotations

import pytest

from zenav.common.client import Client
from zenav.common.config import Settings
from zenav.common.stack import InProcessStack, Router


@pytest.fixture
def router():
    """A Zenoh router in this process on a free loopback port; yields its endpoint."""
    with Router() as r:
        yield r.endpoint


@pytest.fixture
def client(router):
    with Client("r1", router) as c:
        yield c


@pytest.fixture
def make_stack(router):
    """make_stack(services, **settings overrides) -> a started InProcessStack, stopped after the test."""
    stacks = []

    def make(services, **overrides) -> InProcessStack:
        stack = InProcessStack(Settings.load(None, **overrides), router, services)
        stacks.append(stack)
        return stack.start()

    yield make
    for s in reversed(stacks):
        s.stop()
