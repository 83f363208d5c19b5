"""`zenav router` warns when it listens where other hosts reach it without access control."""

from __future__ import annotations

import argparse
import json

import pytest

from zenav.cli import router
from zenav.common.bus import zenoh_config
from zenav.common.config import Limits
from zenav.stack.router import MAX_MESSAGE


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
    monkeypatch.setattr(router, "serve", lambda listen, conf, ready, priority, connect, max_message: ready())
    args = argparse.Namespace(listen="tcp/0.0.0.0:7447", connect=None, zenoh_config=config, realtime=0, max_message=MAX_MESSAGE)
    assert router.run(args) == 0
    err = capsys.readouterr().err
    assert ("warning: tcp/0.0.0.0:7447 is open to other hosts" in err) == warned
    assert "listening on tcp/0.0.0.0:7447" in err


def test_a_realtime_priority_out_of_range_exits_2_saying_so(monkeypatch, capsys):
    monkeypatch.setattr(router, "serve", lambda *a, **k: pytest.fail("served"))
    args = argparse.Namespace(listen="tcp/127.0.0.1:7447", connect=None, zenoh_config=None, realtime=100, max_message=MAX_MESSAGE)
    assert router.run(args) == 2
    assert "--realtime 100: a priority from 1 to 99, or 0" in capsys.readouterr().err


def test_the_router_takes_no_message_over_the_limits_off_a_link(monkeypatch):
    assert MAX_MESSAGE == Limits().max_payload + Limits().max_params + 64 * 1024
    conf = zenoh_config("router", listen="tcp/127.0.0.1:7447", max_message=MAX_MESSAGE)
    assert json.loads(conf.get_json("transport/link/rx/max_message_size")) == MAX_MESSAGE
    served = []
    monkeypatch.setattr(router, "serve", lambda listen, conf, ready, priority, connect, max_message: served.append(max_message))
    parser = argparse.ArgumentParser()
    router.add_arguments(parser.add_subparsers())
    for argv, size in ((["router"], MAX_MESSAGE), (["router", "--max-message", "5000000"], 5_000_000)):
        args = parser.parse_args(argv)
        assert router.run(args) == 0 and served[-1] == size
