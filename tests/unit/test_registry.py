"""The service registry's profiles: what `zenav up --profile` runs, and with which config."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from zenav import services
from zenav.cli.main import main as zenav_main
from zenav.common.app import parse_sets
from zenav.common.config import Settings


def test_the_sim_profile_is_the_default_stack():
    assert services.DEFAULT_PROFILE == "sim"
    assert services.NAMES == services.PROFILES["sim"].services == ("sim", "motor", "odometry", "vps", "localizer", "navigator")
    assert services.PROFILES["sim"].sets() == ["sim.camera=true", 'vps.source="camera"'] and services.PROFILES["sim"].demo
    assert services.PROFILES["sim"].sets(camera=False) == []  # where OpenCV is not installed: the synthetic VPS


def test_compose_runs_the_sim_profile_with_its_settings():
    """docker-compose.yml starts each service itself: it must pass the sim profile's settings."""
    text = (Path(__file__).resolve().parents[2] / "docker-compose.yml").read_text()
    commands = dict(re.findall(r"^  (\w+):\n(?:    .*\n)*?    command: (\[.*\])", text, re.MULTILINE))
    for name in services.NAMES:
        argv = json.loads(commands[name])
        assert argv[:3] == ["python3", "-m", f"zenav.services.{name}"]
        sets = parse_sets([argv[i + 1] for i, a in enumerate(argv) if a == "--set"])
        assert sets.get(name, {}) == parse_sets(services.PROFILES["sim"].sets()).get(name, {}), name


def test_the_robot_profile_runs_the_driver_instead_of_the_sim_on_the_wall_clock():
    robot = services.PROFILES["robot"]
    assert robot.services == ("driver", "motor", "odometry", "localizer", "navigator")
    assert not robot.demo
    assert robot.sets() == ['deployment.clock="wall"']
    assert Settings.load(None, **parse_sets(robot.sets())).deployment.clock == "wall"
    assert services.stop_order(robot.services) == ["navigator", "localizer", "odometry", "motor", "driver"]


@pytest.mark.parametrize("name", sorted(services.PROFILES))
def test_every_profile_names_registered_services_in_start_order(name):
    names = services.PROFILES[name].services
    assert list(names) == [n for n in services.ALL if n in names]
    for n in names:
        assert services.load(n).name == n


def test_the_driver_starts_first_and_stops_last():
    assert services.ALL[0] == "driver"
    assert services.stop_order(services.ALL)[-2:] in (["driver", "sim"], ["sim", "driver"])


def test_up_refuses_the_demo_on_the_robot_profile(capsys):
    assert zenav_main(["up", "--profile", "robot", "--demo"]) == 2
    assert "--demo" in capsys.readouterr().err


def test_tools_judge_the_running_profile_by_the_services_alive():
    assert services.running(set()) == services.NAMES
    assert services.running({"sim", "motor", "navigator"}) == services.NAMES
    assert services.running({"driver", "motor", "odometry"}) == services.PROFILES["robot"].services
    assert services.running({"driver", "motor", "odometry", "vps", "localizer", "navigator"}) == services.PROFILES["robot"].services


def test_every_list_of_services_comes_from_the_one_table():
    from zenav.common import keys, roles

    assert keys.SERVICES == services.ALL == roles.ALL == tuple(r.name for r in roles.TABLE)
    assert {p for r in roles.TABLE for p in r.profiles} == set(services.PROFILES)
    assert roles.ROBOT_SERVICES == ("odometry", "localizer", "navigator", "motor")  # the chain's order, control on pose
    assert set(roles.DRIVE_SERVICES) == set(roles.ROBOT_SERVICES)
    assert roles.CONTROL_LOOP == ("driver", "motor", "odometry", "localizer", "navigator")
    assert roles.ESSENTIAL == ("driver", "motor", "navigator")


def test_the_chain_follows_what_the_control_loop_runs_on():
    from typing import get_args

    from zenav.common import roles
    from zenav.services.navigator.params import ControlOn

    assert roles.CONTROL_ON == get_args(ControlOn) == tuple(roles.OFF_CHAIN)
    assert roles.chain("pose") == roles.ROBOT_SERVICES
    assert roles.chain("odom") == ("odometry", "navigator", "motor")  # the localizer's pose corrects later samples
    # composed in one process, the chain's services subscribe first: a sample reaches them before the localizer
    assert roles.start_order("odom") == ("driver", "sim", "motor", "odometry", "vps", "navigator", "localizer")
    assert roles.start_order("pose") == roles.ALL
