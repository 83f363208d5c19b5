"""`docker compose up`: the whole stack in containers, driven from the host through the published port."""

from __future__ import annotations

import math
import os
import threading
import time

import pytest
import zenoh

from tests.support.docker import IMAGE, REPO, compose_command, run
from tests.support.rawclient import RawClient
from zenav.services import NAMES
from zenav.stack.inprocess import free_port

pytestmark = [pytest.mark.docker, pytest.mark.timeout(900)]

START_TIMEOUT = 120.0  # [s] compose up to every liveliness token
GOAL = (0.5, 0.0)  # [m] map frame
GOAL_TOLERANCE = 0.10  # [m] the navigator's tolerance plus localization error
STOP_WITHIN = 1.0  # [s] kill of the navigator to a stopped robot
STOPPED_SPEED = 0.02  # [m/s] |truth v| that counts as stopped


class Tokens:
    """The services whose liveliness token is up, and when each last went down (monotonic [s])."""

    def __init__(self, client: RawClient) -> None:
        self.alive: set[str] = set()
        self.down_at: dict[str, float] = {}
        self._cond = threading.Condition()
        self._sub = client.session.liveliness().declare_subscriber(f"{client.prefix}/alive/*", self._on_token, history=True)

    def _on_token(self, sample: zenoh.Sample) -> None:
        name = str(sample.key_expr).rsplit("/", 1)[-1]
        with self._cond:
            if sample.kind == zenoh.SampleKind.PUT:
                self.alive.add(name)
            else:
                self.alive.discard(name)
                self.down_at[name] = time.monotonic()
            self._cond.notify_all()

    def wait(self, pred, timeout: float) -> None:
        """Block until pred(alive) is true; TimeoutError otherwise."""
        with self._cond:
            if not self._cond.wait_for(lambda: pred(self.alive), timeout):
                raise TimeoutError(f"not met in {timeout:.0f} s; alive: {sorted(self.alive)}")

    def close(self) -> None:
        self._sub.undeclare()


def speed(latest: dict) -> float:
    """|v| of the newest truth sample [m/s]."""
    return abs(latest["sim/truth"]["v"])


def kill_inside(container) -> None:
    """Crash a container as a fault would: SIGKILL every process but its init.

    The kill spares its own shell, but once the service is dead the init exits and the
    container goes down, killing that shell too if it has not yet returned: 137 (SIGKILL)
    then means the kill worked, as 0 does. What the test asserts next is the crash's effect.
    """
    exit_code, output = container.exec_run(["sh", "-c", "kill -KILL -1"])
    assert exit_code in (0, 128 + 9), (exit_code, output)


def test_compose_stack_drives_the_robot_and_survives_a_crash(engine, image_mb):
    compose = compose_command()
    project = f"zenavtest{os.getpid()}"
    port = free_port()
    env = {**os.environ, "ZENAV_IMAGE": IMAGE, "ZENAV_PORT": str(port), "ZENAV_ROBOT": "r1"}
    cmd = [*compose, "--project-name", project, "--file", str(REPO / "docker-compose.yml")]
    in_project = f"com.docker.compose.project={project}"  # the label compose gives its containers
    client = tokens = None
    try:
        run([*cmd, "config", "--quiet"], env=env)
        t0 = time.monotonic()
        run([*cmd, "up", "--detach", "--no-build"], env=env)
        client = RawClient(f"tcp/127.0.0.1:{port}")
        tokens = Tokens(client)
        tokens.wait(lambda alive: alive >= set(NAMES), START_TIMEOUT - (time.monotonic() - t0))
        start_s = time.monotonic() - t0
        client.follow("sim/truth", keep=True)
        client.follow("pose")
        client.wait(lambda latest: "pose" in latest and "sim/truth" in latest, timeout=30)
        client.wait_nav_ready(timeout=30)

        # a goal through the published port: the reply says succeeded, the truth agrees
        # 3 cm: the final re-check judges a fused pose that late fixes move (this test is about the deployment)
        ok, reply = client.query("nav/move_to_point", {"x": GOAL[0], "y": GOAL[1], "tolerance": 0.03, "wait": True}, timeout=60)
        assert ok, reply
        assert reply["result"] == "succeeded", reply
        truth = client.wait(lambda latest: speed(latest) < STOPPED_SPEED, timeout=5)["sim/truth"]
        goal_error = math.hypot(truth["x"] - GOAL[0], truth["y"] - GOAL[1])
        assert goal_error < GOAL_TOLERANCE, truth

        # the navigator crashes while driving: the robot stops within 1 s, the navigator comes back
        ok, reply = client.query("nav/move_to_point", {"x": 2.5, "y": 0.0}, timeout=10)
        assert ok, reply
        client.wait(lambda latest: speed(latest) > 0.05, timeout=10)
        (navigator,) = engine.containers.list(filters={"label": [in_project, "com.docker.compose.service=navigator"]})
        kill_inside(navigator)
        tokens.wait(lambda alive: "navigator" not in alive, timeout=5)
        t_kill = tokens.down_at["navigator"]  # the router saw the navigator's session end
        client.wait(lambda latest: speed(latest) < STOPPED_SPEED, timeout=STOP_WITHIN - (time.monotonic() - t_kill))
        stop_s = time.monotonic() - t_kill
        stopped_from = len(client.history["sim/truth"])
        tokens.wait(lambda alive: "navigator" in alive, timeout=60)
        back_s = time.monotonic() - t_kill
        navigator.reload()
        assert navigator.attrs["RestartCount"] >= 1
        ok, status = client.query("nav/status", timeout=10)
        assert ok and status["state"] == "STOPPED" and not status["is_moving"], status
        # still at rest through the restart: no sample since the stop moved
        assert max(abs(t["v"]) for t in client.history["sim/truth"][stopped_from:]) < STOPPED_SPEED

        print(
            f"\ncompose figures: image {IMAGE} {image_mb:.0f} MB; start to all alive {start_s:.1f} s; "
            f"goal ({GOAL[0]}, {GOAL[1]}) truth error {goal_error:.3f} m; "
            f"navigator killed: robot stopped in {stop_s:.2f} s, navigator back in {back_s:.1f} s"
        )
    except BaseException:
        for c in engine.containers.list(all=True, filters={"label": in_project}):
            print(f"--- {c.name} ({c.status})\n{c.logs(tail=30).decode(errors='replace')}")
        raise
    finally:
        if tokens is not None:
            tokens.close()
        if client is not None:
            client.close()
        run([*cmd, "down", "--volumes", "--timeout", "10"], env=env)
        assert engine.containers.list(all=True, filters={"label": in_project}) == []
