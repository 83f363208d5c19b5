"""The navigator's leases and instances: bounded lease keys, goals without a lease, one navigator per robot."""

from __future__ import annotations

import pytest

from tests.support.navigator import reply
from zenav.common import codec
from zenav.common.clock import ManualClock
from zenav.common.config import Settings
from zenav.common.runtime import LOG_CHARS, Duplicate
from zenav.services.navigator.service import LEASE_CHARS, Navigator


def test_an_over_long_lease_is_invalid(rig):
    lease = "zenav/r1/lease/" + "a" * LEASE_CHARS
    err = reply(rig.query("nav/move_to_point", {"x": 1.0, "y": 0.0, "lease": lease}))
    assert err.error == "invalid_argument" and f"over {LEASE_CHARS}" in err.message and lease not in err.message
    assert rig.nav.machine.state == "STOPPED"


def test_a_goal_without_a_lease_runs_on_when_a_lease_goes(rig):
    token = rig.bus.token("zenav/r1/lease/someone")
    q = rig.query("nav/move_to_point", {"x": 1.0, "y": 0.0})
    rig.step(10)
    token.undeclare()
    rig.step(10)
    assert reply(q).goal_id == 1 and rig.nav.machine.state == "MOVING_TO_POINT" and rig.cmd[0] > 0.0


def test_a_decode_error_naming_a_long_field_is_clipped(rig):
    q = rig.bus.query("zenav/r1/nav/move_to_point", codec.encode({"x": 1.0, "y": 0.0, "b" * 5000: 1}))
    rig.nav.drain()
    err = reply(q)
    assert err.error == "invalid_argument" and "unknown field" in err.message
    assert len(err.message) < LOG_CHARS + 50, len(err.message)


def test_a_second_navigator_is_refused_and_the_first_shows_a_newcomer(rig):
    second = Navigator(Settings.load(None), rig.bus, ManualClock(100.0))
    with pytest.raises(Duplicate, match=f"another navigator already runs for robot r1 \\({rig.nav.instance}\\)"):
        second.start()
    sent = len(rig.bus.published)
    second.close()
    assert len(rig.bus.published) == sent  # the refused one commands nothing (no zero on close)
    # one that started at the same moment, unseen by the check: its instance token tells the first
    token = rig.bus.token("zenav/r1/instance/navigator/other-1")
    rig.nav.drain()
    d = rig.nav.diag(rig.clock.now())
    assert d.status == "error" and "another navigator runs for robot r1: other-1" in d.message
    token.undeclare()
    rig.nav.drain()
    assert rig.nav.diag(rig.clock.now()).status == "ok"
