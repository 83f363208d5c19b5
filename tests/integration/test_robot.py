"""The robot library through a real router, against the in-process stack."""

from __future__ import annotations

import math
import subprocess
import sys
import time

import pytest

from zenav.common.client import Client
from zenav.robot import InvalidArgument, Robot, Unavailable
from zenav.stack.inprocess import free_port

SERVICES = ["sim", "motor", "odometry", "vps", "localizer", "navigator"]
RTF = 1.0  # realtime: six services share this process (one GIL) on a busy host
NAV = {"stale_after": 2.0, "progress_timeout": 20.0}  # a host stalling the stack is not the library's subject
HOLDER = """
import sys
from zenav import Robot

bot = Robot("r1", sys.argv[1])
bot.wait_ready(timeout=60)
print(bot.move_to_point(2.0, 0.0).id, flush=True)
sys.stdin.read()  # hold the robot (and its lease) until killed
"""


@pytest.fixture
def stack(make_stack, router):
    make_stack(SERVICES, sim={"rtf": RTF}, navigator=NAV)
    with Client("r1", router) as watcher:
        yield watcher


def test_goals_feedback_preemption_cancel_and_stop(stack, router):
    with Robot("r1", router) as bot:
        bot.wait_ready(timeout=60)
        with pytest.raises(InvalidArgument, match="speed"):
            bot.move_straight(0.0)  # refused by the navigator, naming the field

        goal = bot.move_to_point(0.3, 0.0, speed=0.2, tolerance=0.01)
        remaining = [st.distance_remaining for st in goal.updates(timeout=60) if st.result is None]
        res = goal.wait(timeout=1)
        assert res.succeeded and math.hypot(res.pose.x - 0.3, res.pose.y) < 0.03 and not bot.is_moving()
        assert len(remaining) >= 3 and remaining[0] > 0.2 and remaining[-1] < remaining[0]

        first = bot.move_to_point(1.0, 0.0)
        next(first.updates(timeout=30))  # running
        second = bot.turn_to_heading(math.pi / 2)
        res = first.wait(timeout=10)
        assert res.result == "cancelled" and res.message == f"preempted by goal {second.id}"
        assert not first.cancel() and bot.is_moving()
        assert second.cancel() and second.wait(timeout=10).result == "cancelled"

        straight = bot.move_straight(0.1)
        next(straight.updates(timeout=30))
        assert bot.stop() == "STOPPED"
        assert straight.wait(timeout=10).result == "cancelled" and not bot.is_moving()
        # At rest: neither driving nor turning. Stopped just after the turn was cancelled, the robot may
        # not have driven yet (|v| already small) while the turn's start still spins down.
        stack.latest("sim/truth").wait(lambda t: abs(t.v) < 0.01 and abs(t.omega) < 0.05, timeout=10)


def test_drive_backs_the_robot_into_the_wall_where_it_squares_up(make_stack, router):
    # 15 cm from the wall x_min = -1 behind it, turned 10 deg: a back corner meets the wall first.
    make_stack(SERVICES, sim={"rtf": RTF, "x0": -0.77, "theta0": math.radians(10.0)}, navigator=NAV)
    with Client("r1", router) as watcher, Robot("r1", router) as bot:
        bot.wait_ready(timeout=60)
        bot.drive(-0.15, 0.0, seconds=2.0)  # 30 cm of wheel travel
        truth = watcher.latest("sim/truth").wait(lambda t: abs(t.v) < 0.01 and abs(t.omega) < 0.01, timeout=10)
        assert truth.theta == pytest.approx(0.0, abs=1e-6) and truth.x == pytest.approx(-1.0 + 0.08)  # its back flat on it
        watcher.latest("diag/sim").wait(lambda d: d.counters["contacts"] >= 1, timeout=10)
        # The pose turned with it, most of the way at once: the gyro felt what the encoders did not (they say 10 deg still).
        assert abs(bot.pose().theta) < math.radians(5.0)


def test_a_move_that_a_wall_holds_short_ends_short_not_arrived(make_stack, router):
    # The wall x_min = -1 stops the chassis's front at x = -0.92: the target lies 5 cm beyond, inside the field.
    make_stack(SERVICES, sim={"rtf": RTF, "x0": -0.6, "theta0": math.pi}, navigator=NAV)  # held where it stops: no retry
    with Client("r1", router) as watcher, Robot("r1", router) as bot:
        bot.wait_ready(timeout=60)
        res = bot.move_to_point(-0.97, 0.0, speed=0.2).wait(timeout=60)
        # The odometry alone says it got there; the accelerometer felt the wall, so the verdict waited for the fixes.
        assert res.result == "aborted" and "the wheels slipped" in res.message, res.message
        truth = watcher.latest("sim/truth").wait(lambda t: abs(t.v) < 0.01, timeout=10)
        assert truth.x == pytest.approx(-0.92, abs=0.002)
        watcher.latest("pose").wait(lambda p: abs(p.x - truth.x) < 0.01, timeout=10)
        assert watcher.latest("diag/localizer").wait(lambda d: d.counters.get("impacts", 0) >= 1, timeout=10)


def test_a_program_that_dies_stops_the_robot(stack, router):
    holder = subprocess.Popen([sys.executable, "-c", HOLDER, router], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        goal_id = int(holder.stdout.readline())
        stack.latest("sim/truth").wait(lambda t: t.v > 0.1, timeout=30)
        holder.kill()
        holder.wait(timeout=10)
        stack.latest("sim/truth").wait(lambda t: abs(t.v) < 0.01, timeout=5)
        st = stack.latest("nav/state").wait(lambda s: s.goal_id == goal_id and s.result is not None, timeout=5)
        assert st.result == "aborted" and st.message.startswith("lease lost: zenav/r1/lease/")
    finally:
        holder.kill()
        holder.wait(timeout=10)
        holder.stdin.close()
        holder.stdout.close()


def test_no_router_is_unavailable_fast():
    started = time.monotonic()
    with pytest.raises(Unavailable, match="no Zenoh router"):
        Robot("r1", f"tcp/127.0.0.1:{free_port()}", connect_timeout=0.5)
    assert time.monotonic() - started < 5.0
