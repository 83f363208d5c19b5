"""`docker compose up`, both profiles, on the image compose builds from this checkout: the
simulated stack driven from the host through the published port, healthy, surviving a
crash; the robot profile's container driving the emulated motor board passed in."""

from __future__ import annotations

import math
import re
import threading
import time

import pytest
import zenoh

from tests.support.docker import IMAGE, Project, dialout_pty
from tests.support.rawclient import RawClient
from zenav.services import NAMES, PROFILES
from zenav.stack.inprocess import free_port
from zenav.tools.arduino_emulator import Emulator

pytestmark = [pytest.mark.docker, pytest.mark.timeout(900)]

START_TIMEOUT = 120.0  # [s] compose up to every liveliness token
GOAL = (0.5, 0.0)  # [m] map frame
GOAL_TOLERANCE = 0.10  # [m] the navigator's tolerance plus localization error
STOP_WITHIN = 1.0  # [s] kill of the navigator to a stopped robot
STOPPED_SPEED = 0.02  # [m/s] |truth v| that counts as stopped
HEALTHY_WITHIN = 120.0  # [s] compose up to every container healthy (the first check comes 30 s after the start)
TICKS = 1440  # [ticks/rev] the emulated board's encoders, and the robot config's
ROBOT_CONFIG = f"""
[robot]
ticks_per_rev = {TICKS}
[driver]
open_delay = 0.0
[odometry]
heading_source = "encoders"
[localizer]
calib_sigma = 0.002
"""  # a calibrated robot with no VPS (as tests/integration/test_robot_profile.py)


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
    port = free_port()
    with Project(engine, {"ZENAV_PORT": str(port), "ZENAV_ROBOT": "r1"}) as project:
        project.compose("config", "--quiet")
        since, t0 = time.time(), time.monotonic()
        project.compose("up", "--detach", "--no-build")
        client = RawClient(f"tcp/127.0.0.1:{port}")
        tokens = Tokens(client)
        try:
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

            # every container healthy, as `compose ps` shows; a service's healthcheck fails while it is missing
            project.wait_healthy(["router", *NAMES], since, HEALTHY_WITHIN - (time.monotonic() - t0))
            healthy_s = time.monotonic() - t0
            rows = project.compose("ps").splitlines()
            for name in ["router", *NAMES]:  # containers named project_service_1 (Compose v1) or project-service-1 (v2)
                assert any(re.match(rf"{project.name}[-_]{name}[-_]1 .*\(healthy\)", row) for row in rows), rows
            code, output = project.container("navigator").exec_run(["zenav", "status", "--service", "navigator", "--service", "driver"])
            assert code == 3 and output.decode().strip() == "robot r1: navigator alive, driver not alive", (code, output)

            # the navigator crashes while driving: the robot stops within 1 s, the navigator comes back
            ok, reply = client.query("nav/move_to_point", {"x": 2.5, "y": 0.0}, timeout=10)
            assert ok, reply
            client.wait(lambda latest: speed(latest) > 0.05, timeout=10)
            navigator = project.container("navigator")
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
        finally:
            tokens.close()
            client.close()
    print(
        f"\ncompose figures: image {IMAGE} {image_mb:.0f} MB; start to all alive {start_s:.1f} s, all healthy {healthy_s:.1f} s; "
        f"goal ({GOAL[0]}, {GOAL[1]}) truth error {goal_error:.3f} m; "
        f"navigator killed: robot stopped in {stop_s:.2f} s, navigator back in {back_s:.1f} s"
    )


def test_robot_profile_drives_the_board_passed_in(engine, image_mb, tmp_path):
    """The `robot` container (`zenav up --profile robot` as the image's user) against the
    emulated board on a pty, passed in by ZENAV_BOARD as compose's device; a goal from the
    host drives the board's wheels. A pty's node opens only on its own devpts (a copy of it,
    which is what a device passed in is, fails with EIO): the override binds the node itself
    over the device's path. A real serial port needs no such thing."""
    port = free_port()
    (tmp_path / "robot.toml").write_text(ROBOT_CONFIG)
    with Emulator(str(tmp_path / "board"), ticks_per_rev=TICKS) as emu:
        try:
            pty = dialout_pty(emu.link)  # as udev makes a USB serial port: only a user in dialout opens it
        except PermissionError:
            pytest.skip("giving the pty to the dialout group needs root or membership of dialout")
        override = tmp_path / "pty.yml"
        override.write_text(f'services:\n  robot:\n    volumes:\n      - "{pty}:/dev/zenav-board"\n')
        env = {"ZENAV_PORT": str(port), "ZENAV_BOARD": emu.link, "ZENAV_ROBOT_CONFIG": str(tmp_path / "robot.toml")}
        with Project(engine, env, [override]) as project:
            since, t0 = time.time(), time.monotonic()
            project.compose("--profile", "robot", "up", "--detach", "--no-build", "router", "robot")
            robot = PROFILES["robot"].services
            client = RawClient(f"tcp/127.0.0.1:{port}")
            tokens = Tokens(client)
            try:
                tokens.wait(lambda alive: alive >= set(robot), START_TIMEOUT - (time.monotonic() - t0))
                start_s = time.monotonic() - t0
                client.follow("diag/driver")
                client.follow("pose")
                client.wait(lambda latest: latest.get("diag/driver", {}).get("status") == "ok", timeout=30)  # the board answered
                ok, reply = client.query("localizer/set_pose", {"x": 0.0, "y": 0.0, "theta": 0.0}, timeout=10)  # no VPS here
                assert ok, reply
                client.wait_nav_ready(timeout=30)
                before = emu.counts()
                ok, reply = client.query("nav/move_to_point", {"x": 0.3, "y": 0.0, "tolerance": 0.03, "wait": True}, timeout=60)
                assert ok and reply["result"] == "succeeded", reply
                after = emu.counts()
                assert after[0] - before[0] > TICKS / 2 and after[1] - before[1] > TICKS / 2, (before, after)  # both wheels turned
                project.wait_healthy(["router", "robot"], since, HEALTHY_WITHIN - (time.monotonic() - t0))
                healthy_s = time.monotonic() - t0
                code, output = project.container("robot").exec_run(["id", "-nG"])
                assert code == 0 and "dialout" in output.decode().split(), output
                assert {c.labels["com.docker.compose.service"] for c in engine.containers.list(filters={"label": project.label})} == {
                    "router",
                    "robot",
                }  # the simulated services stayed down
            finally:
                tokens.close()
                client.close()
    print(
        f"\nrobot profile figures: start to the five services alive {start_s:.1f} s, healthy {healthy_s:.1f} s; "
        f"a 0.3 m goal turned the board's wheels {after[0] - before[0]} and {after[1] - before[1]} ticks"
    )
