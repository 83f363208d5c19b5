"""`zenav router` warns when it listens where other hosts reach it without access control."""

from __future__ import annotations

import argparse

import pytest

from zenav.cli import router


@pytest.mark.parametrize(
    ("listen", "open_to"),
    [
        ("tcp/127.0.0.1:7447", []),
        ("tcp/localhost:7447", []),
        ("tcp/[::1]:7447", []),
        ("tcp/0.0.0.0:7447", ["tcp/0.0.0.0:7447"]),
        ("tcp/127.0.0.1:7447,tls/192.168.1.20:7448", ["tls/192.168.1.20:7448"]),
        ("tcp/robot.lan:7447", ["tcp/robot.lan:7447"]),
        ("unixsock-stream//run/zenav/router.sock,tcp/10.77.0.1:7447", ["tcp/10.77.0.1:7447"]),
    ],
)
def test_exposed_names_the_endpoints_other_hosts_reach(listen, open_to):
    assert router.exposed(listen) == open_to


@pytest.mark.parametrize(("config", "warned"), [(None, True), ("acl.json5", False)])
def test_an_open_router_without_access_control_warns(monkeypatch, capsys, config, warned):
    monkeypatch.setattr(router, "serve", lambda listen, conf, ready, priority, connect: ready())
    args = argparse.Namespace(listen="tcp/0.0.0.0:7447", connect=None, zenoh_config=config, realtime=0)
    assert router.run(args) == 0
    err = capsys.readouterr().err
    assert ("warning: tcp/0.0.0.0:7447 is open to other hosts" in err) == warned
    assert "listening on tcp/0.0.0.0:7447" in err


def test_a_realtime_priority_out_of_range_exits_2_saying_so(monkeypatch, capsys):
    monkeypatch.setattr(router, "serve", lambda *a, **k: pytest.fail("served"))
    assert router.run(argparse.Namespace(listen="tcp/127.0.0.1:7447", connect=None, zenoh_config=None, realtime=100)) == 2
    assert "--realtime 100: a priority from 1 to 99, or 0" in capsys.readouterr().err
