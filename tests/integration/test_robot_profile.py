"""The robot profile end to end: the emulated motor board on a pty, a real router, the
profile's services on the wall clock, and a library program driving a 1 m square; then
the board unplugged mid-goal (the goal aborts, saying so) and plugged back in (a new
goal succeeds)."""

from __future__ import annotations

import math
import threading

import pytest

from zenav import services
from zenav.common.app import parse_sets
from zenav.common.client import Client, Latest
from zenav.common.config import Settings
from zenav.robot import Robot
from zenav.services.navigator.params import Params
from zenav.stack.inprocess import InProcessStack
from zenav.tools.arduino_emulator import Emulator

TICKS = 1440  # [ticks/rev] the emulated encoders, and [robot] ticks_per_rev
SPEED = 0.15  # [m/s] moderate: the board's PID holds it, the host keeps up
TOLERANCE = 0.03  # [m] each corner
CALIB_SIGMA = 0.002  # a calibrated robot (`zenav calibrate`): with no VPS the filter cannot learn the calibration
NAV = {"stale_after": 1.0, "progress_timeout": 20.0}  # a busy host may stall the stack; the driver's abort comes first
DRIVER = {"open_delay": 0.0, "reply_timeout": 0.2, "reconnect_period": 0.2}
SQUARE = [(1.0, 0.0), (1.0, 1.0), (0.0, 1.0), (0.0, 0.0)]
GOAL_WAIT = 25.0  # [s] one corner, at most
WAIT = 10.0  # [s] one condition, at most
SAMPLE = 0.01  # [s] the truth integrates the board's counts this often


class BoardTruth:
    """The board's own pose: its wheel counts integrated (midpoint) with the robot's geometry, from (0, 0, 0)."""

    def __init__(self, emu: Emulator, wheel_radius: float, track: float) -> None:
        self.emu, self.r, self.track = emu, wheel_radius, track
        self.x = self.y = self.theta = 0.0  # [m], [m], [rad]
        self.prev = emu.counts()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def sample(self) -> None:
        """Integrate the counts since the last sample."""
        left, right = self.emu.counts()
        dl = (left - self.prev[0]) * 2.0 * math.pi / TICKS * self.r  # [m]
        dr = (right - self.prev[1]) * 2.0 * math.pi / TICKS * self.r  # [m]
        self.prev = (left, right)
        dth = (dr - dl) / self.track
        mid = self.theta + dth / 2.0
        self.x += (dl + dr) / 2.0 * math.cos(mid)
        self.y += (dl + dr) / 2.0 * math.sin(mid)
        self.theta += dth

    def _run(self) -> None:
        while not self._stop.wait(SAMPLE):  # measuring, not synchronising: ends with stop()
            self.sample()

    def stop(self) -> tuple[float, float, float]:
        """Stop sampling; the pose after a last sample."""
        self._stop.set()
        self._thread.join(timeout=WAIT)
        self.sample()
        return self.x, self.y, self.theta


@pytest.fixture
def emu(tmp_path):
    with Emulator(str(tmp_path / "board"), ticks_per_rev=TICKS) as e:
        yield e


def robot_settings(emu: Emulator, localizer: dict) -> Settings:
    """The robot profile's settings for the emulated board."""
    profile = services.PROFILES["robot"]
    settings = Settings.load(
        None,
        **{
            **parse_sets(profile.sets()),
            "robot": {"ticks_per_rev": TICKS},
            "driver": {"port": emu.link, **DRIVER},
            "odometry": {"heading_source": "encoders"},
            "localizer": localizer,
            "navigator": NAV,
        },
    )
    assert settings.deployment.clock == "wall"
    return settings


@pytest.fixture
def robot_stack(emu, router):
    with InProcessStack(robot_settings(emu, {"calib_sigma": CALIB_SIGMA}), router, services.PROFILES["robot"].services) as stack:
        yield stack


def test_an_uncalibrated_robot_without_a_vps_drives_its_first_goal(emu, router):
    """The localizer's default calibration prior (5 %) grows the heading sigma past [navigator] max_heading_sigma
    within the first metre: with no vps, the goal drives, and nav/state says how uncertain the pose is."""
    limit = Settings.load(None).section("navigator", Params).max_heading_sigma
    with (
        InProcessStack(robot_settings(emu, {}), router, services.PROFILES["robot"].services),
        Client("r1", router) as watcher,
        Robot("r1", router, lease=False) as bot,
    ):
        watcher.latest("diag/driver").wait(lambda d: d.status == "ok", timeout=WAIT)
        state: Latest = watcher.latest("nav/state")
        bot.set_pose(0.0, 0.0, 0.0)
        bot.wait_ready(timeout=30)
        end = bot.move_to_point(1.0, 0.0, speed=SPEED, tolerance=TOLERANCE).wait(timeout=GOAL_WAIT)
        assert end.succeeded, str(end)
        last = state.wait(lambda s: s.goal_id == end.goal_id and s.result is not None, timeout=WAIT)
        print(f"\nheading sigma at the end {last.heading_sigma:.3f} rad (limit {limit} rad), position {last.position_sigma:.3f} m")
        assert last.heading_sigma > limit, last


def test_the_robot_profile_drives_the_board_and_survives_an_unplug(emu, robot_stack, router):
    r = robot_stack.settings.robot
    with Client("r1", router) as watcher, Robot("r1", router, lease=False) as bot:  # no lease: its 0.3 s transport lease is not the subject
        diag: Latest = watcher.latest("diag/driver")
        encoders: Latest = watcher.latest("sensors/encoders")
        odom: Latest = watcher.latest("odom")
        diag.wait(lambda d: d.status == "ok", timeout=WAIT)  # the handshake is done: counts from 0
        encoders.wait(timeout=WAIT)
        truth = BoardTruth(emu, r.wheel_radius, r.track_width)
        bot.set_pose(0.0, 0.0, 0.0)  # no VPS on this robot
        bot.wait_ready(timeout=30)

        for x, y in SQUARE:
            end = bot.move_to_point(x, y, speed=SPEED, tolerance=TOLERANCE).wait(timeout=GOAL_WAIT)
            assert end.succeeded, str(end)
        assert emu.wait(lambda: emu.pwm() == (0, 0), WAIT), "the board still drives after the last goal"
        still = encoders.wait(lambda e: (e.left, e.right) == emu.counts(), timeout=WAIT)  # the wheels stand still
        tx, ty, tth = truth.stop()
        o = odom.wait(lambda o: o.t >= still.t, timeout=WAIT)
        print(
            f"\nsquare end: board ({tx:+.4f}, {ty:+.4f}, {math.degrees(tth):+.2f} deg), odometry minus board "
            f"{math.hypot(o.x - tx, o.y - ty) * 1e3:.1f} mm, {math.degrees(math.remainder(o.theta - tth, math.tau)):+.3f} deg"
        )
        assert math.hypot(tx, ty) < 2 * TOLERANCE, f"the board ended at ({tx:.3f}, {ty:.3f})"
        assert math.hypot(o.x - tx, o.y - ty) < 0.01, f"odometry ({o.x:.3f}, {o.y:.3f}) vs board ({tx:.3f}, {ty:.3f})"
        assert abs(math.remainder(o.theta - tth, math.tau)) < math.radians(1.0)

        goal = bot.move_to_point(1.0, 0.0, speed=SPEED)
        assert emu.wait(lambda: emu.pwm() != (0, 0), WAIT), "the board never moved for the goal"
        emu.unplug()
        end = goal.wait(timeout=WAIT)
        assert end.result == "aborted" and end.message.startswith("driver: disconnected"), str(end)
        assert emu.wait(lambda: emu.pwm() == (0, 0), WAIT), "the firmware's auto-stop did not stop the wheels"

        emu.replug()
        diag.wait(lambda d: d.status == "ok" and d.counters.get("reconnects", 0) >= 1, timeout=WAIT)
        before = encoders.count
        encoders.wait(lambda e: encoders.count > before + 10, timeout=WAIT)  # encoders flow again
        bot.wait_ready(timeout=30)
        end = bot.move_to_point(0.0, 0.0, speed=SPEED, tolerance=TOLERANCE).wait(timeout=GOAL_WAIT)
        assert end.succeeded, str(end)
