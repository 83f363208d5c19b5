"""`zenav record`, `view` and `replay` with no router: one line and exit 3 within seconds, not a silent hang."""

from __future__ import annotations

import socket
import subprocess
import sys
import time

from mcap.writer import Writer

from tests.support.procs import reaped
from zenav.cli.main import EXIT_UNAVAILABLE
from zenav.cli.session import CONNECT_TIMEOUT

STARTUP = 10.0  # [s] for Python to start and import zenav on a loaded machine


def unused_endpoint() -> str:
    """A loopback endpoint where nothing listens."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return f"tcp/127.0.0.1:{s.getsockname()[1]}"


def test_each_tool_gives_up_on_a_missing_router_with_one_line(tmp_path):
    recording = tmp_path / "in.mcap"
    w = Writer(str(recording))
    w.start()
    w.finish()
    endpoint = unused_endpoint()
    commands = {
        "record": ["record", str(tmp_path / "out.mcap"), "--duration", "1"],
        "view": ["view", "--port", "0"],
        "replay": ["replay", str(recording)],
    }
    t0 = time.monotonic()
    procs = {
        name: subprocess.Popen(
            [sys.executable, "-m", "zenav", *argv, "--connect", endpoint], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
        )
        for name, argv in commands.items()
    }
    with reaped(*procs.values()):
        results = {name: (proc.wait(timeout=STARTUP + CONNECT_TIMEOUT + 5), *proc.communicate(timeout=5)) for name, proc in procs.items()}
    assert time.monotonic() - t0 < STARTUP + CONNECT_TIMEOUT + 5
    for name, (code, out, err) in results.items():
        assert code == EXIT_UNAVAILABLE, (name, err)
        lines = err.splitlines()
        assert out == "" and len(lines) == 1 and lines[0].startswith(f"zenav {name}: no Zenoh router at {endpoint} ("), (name, err)
        assert ".rs:" not in err and "Traceback" not in err  # Zenoh's source lines stay out
    assert not (tmp_path / "out.mcap").exists() and not (tmp_path / "out.mcap.part").exists()
