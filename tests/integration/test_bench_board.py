"""The robot computer's cost: the robot profile's real processes and its camera's vps on the emulated board over a pty."""

from __future__ import annotations

from zenav.bench import board
from zenav.common import messages as m
from zenav.common.roles import ROBOT_SERVICES


def test_the_robot_profile_drives_the_emulated_board_and_each_process_is_measured(tmp_path):
    r = board.run(2.0, tmp_path, compose=ROBOT_SERVICES)
    assert set(r.cores) == {"router", "driver", "vps", "composed"}  # the driver and the vps apart, the four together
    assert all(c > 0.0 for c in r.cores.values()), r.cores
    assert r.robot == r.cores["driver"] + r.cores["vps"] + r.cores["composed"]
    assert r.encoders_hz > 50.0  # the driver polls the board at its sensor rate (100 Hz), the odometry takes them
    assert r.latency.n > 50 and 0.0 < r.latency.p50 < r.latency.max < 1e3  # each command's age, from the sample it was made from
    assert r.goal_failures == []
    assert r.fixes[0] > 0  # the camera's frames became fixes the localizer took


def test_a_wheel_command_made_from_no_sample_has_no_age():
    ages: list[float] = []
    board._age(m.Wheels(t=0.0, left=0.0, right=0.0), ages)  # a stop's zero: "now"
    assert ages == []
    board._age(m.Wheels(t=1.0, left=0.0, right=0.0), ages)  # an encoder sample's, stamped on the wall clock
    assert len(ages) == 1 and ages[0] > 1e6
