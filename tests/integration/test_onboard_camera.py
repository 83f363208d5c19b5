"""The robot's own camera through a real router: the sim renders it, a vps reads it, beside the overhead camera's vps."""

from __future__ import annotations

import math

import pytest

from zenav.common.client import Client
from zenav.robot import Robot

pytest.importorskip("cv2")

SERVICES = ["sim", "motor", "odometry", "vps", "localizer", "navigator"]
NAV = {"stale_after": 2.0, "progress_timeout": 20.0}


def test_the_onboard_camera_alone_localizes_the_driving_robot(make_stack, router):
    make_stack(SERVICES, vps={"source": "onboard"}, sim={"x0": 0.3, "y0": 0.5}, navigator=NAV)
    with Client("r1", router) as watcher, Robot("r1", router) as bot:
        bot.wait_ready(timeout=60)
        assert bot.move_to_point(1.0, 0.5).wait(timeout=60).result == "succeeded"
        truth = watcher.latest("sim/truth").wait(lambda t: abs(t.v) < 0.01 and abs(t.omega) < 0.01, timeout=10)
        pose = bot.pose()
        assert math.hypot(pose.x - truth.x, pose.y - truth.y) < 0.01  # [m] at rest, fixes of the wall tags ahead
        diag = watcher.latest("diag/vps").wait(lambda d: d.counters.get("fixes_captured", 0) >= 10, timeout=10)
        assert diag.counters.get("frames_refused", 0) == 0


def test_a_second_cameras_vps_runs_beside_the_first_and_both_are_fused(make_stack, router):
    make_stack(SERVICES, sim={"onboard_camera": True}, vps={"source": "synthetic"}, navigator=NAV)
    make_stack(["vps"], vps={"source": "onboard", "name": "onboard"})
    with Client("r1", router) as watcher:
        fixes = watcher.latest("localizer/fixes")
        # The synthetic camera's fixes are ~0.3 s late, the onboard camera's ~0.06 s: both kinds get accepted.
        fixes.wait(lambda f: f.accepted and f.latency > 0.2, timeout=30)
        fixes.wait(lambda f: f.accepted and f.latency < 0.15, timeout=30)
        assert {"vps", "vps_onboard"} <= watcher.wait_alive(["vps", "vps_onboard"], timeout=10)
