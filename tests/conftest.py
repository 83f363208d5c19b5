"""Fixtures shared by the test suites: a clean environment, a real router, an in-process stack, a client, a Docker engine."""

from __future__ import annotations

import os

import pytest

from tests.support.docker import BUILD, no_engine
from zenav.common.client import Client
from zenav.common.config import Settings
from zenav.stack.inprocess import InProcessStack
from zenav.stack.router import Router

ZENOH_VARIABLES = ("ZENOH_CONNECT", "ZENOH_MODE", "ZENOH_CONFIG")


def pytest_collection_finish(session: pytest.Session) -> None:
    """Start building the images now if a docker test is to run: the tests before it run meanwhile."""
    if any(item.get_closest_marker("docker") for item in session.items) and no_engine() is None:
        BUILD.start()


@pytest.fixture(autouse=True)
def clean_environment(monkeypatch):
    """No ZENAV_* (nor ZENOH_CONNECT, ZENOH_MODE, ZENOH_CONFIG) from the user's shell reaches a test."""
    for name in list(os.environ):
        if name.startswith("ZENAV_") or name in ZENOH_VARIABLES:
            monkeypatch.delenv(name)


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


@pytest.fixture(scope="session")
def engine():
    """A docker SDK client of an engine that answers; skip otherwise."""
    docker = pytest.importorskip("docker", reason="the docker Python SDK is not installed (pip install docker)")
    why = no_engine()  # asked with the CLI first: the SDK leaks a socket when no engine answers
    if why is not None:
        pytest.skip(why)
    client = docker.from_env()
    yield client
    client.close()


@pytest.fixture(scope="session")
def image_mb(engine) -> float:
    """The zenav image built once a session from this checkout (the base too, if absent); its size [MB]."""
    return BUILD.result()
