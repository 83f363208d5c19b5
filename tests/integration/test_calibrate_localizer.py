"""`zenav calibrate --from-localizer` against a running stack (sim, odometry, vps, localizer on a real router):
the geometry the localizer has learnt while the robot turned is written into [robot]."""

from __future__ import annotations

import sys

import pytest

if sys.version_info >= (3, 11):
    import tomllib
else:
    import tomli as tomllib

from zenav.cli.main import EXIT_UNAVAILABLE, main
from zenav.common import messages as m

RTF = 4.0
TURNING = 8.0  # [s] of stack time the robot turns on the spot (the gyro teaches the track width meanwhile)
WHEELS = 4.0  # [rad/s] each wheel, opposite ways


def test_from_localizer_writes_the_learnt_track_and_wheels_into_the_config(make_stack, client, router, tmp_path, capsys):
    make_stack(["sim", "odometry", "vps", "localizer"], sim={"rtf": RTF})
    client.wait_alive(["sim", "odometry", "vps", "localizer"], timeout=20.0)
    odom = client.latest("odom")
    t0 = odom.wait(timeout=10.0).t
    t = t0
    for _ in range(int(TURNING * 10) + 1):  # a command every 0.1 s of stack time (the sim's command timeout is longer)
        if t >= t0 + TURNING:
            break
        client.publish("motors/wheels", m.Wheels(t=0.0, left=-WHEELS, right=WHEELS))
        t = odom.wait(lambda o, after=t: o.t >= after + 0.1, timeout=5.0).t
    client.publish("motors/wheels", m.Wheels(t=0.0, left=0.0, right=0.0))
    # the robot coasts to a stand before the config is written: turning, it would go on teaching the localizer
    odom.wait(lambda o, after=t: o.t >= after + 0.5 and abs(o.omega) < 1e-3, timeout=10.0)
    learnt = client.query("localizer/pose").calibration
    assert learnt["track_width_scale"] != 1.0  # the robot turned: the localizer learnt something

    config = tmp_path / "robot.toml"
    config.write_text("# my robot\n[robot]\ntrack_width = 0.1156  # nominal\n\n[motor]\nmax_accel = 2.0\n")
    assert main(["calibrate", "--from-localizer", "--connect", router, "--config", str(config)]) == 0
    written = tomllib.loads(config.read_text())
    assert written["motor"] == {"max_accel": 2.0} and config.read_text().startswith("# my robot\n")
    now = client.query("localizer/pose").calibration  # it goes on learning while the robot stands
    assert written["robot"]["track_width"] == pytest.approx(now["track_width"], rel=2e-3)
    assert written["robot"]["wheel_diameter"] == pytest.approx(now["wheel_diameter"], rel=2e-3)
    assert "wrote [robot] wheel_diameter" in capsys.readouterr().out


def test_from_localizer_without_a_localizer_says_so(router, tmp_path, capsys):
    config = tmp_path / "robot.toml"
    config.write_text("[robot]\ntrack_width = 0.1156\n")
    assert main(["calibrate", "--from-localizer", "--connect", router, "--config", str(config)]) == EXIT_UNAVAILABLE
    assert "the localizer" in capsys.readouterr().err and config.read_text() == "[robot]\ntrack_width = 0.1156\n"
