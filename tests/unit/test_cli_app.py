"""The options of a process that connects and of one that deploys; config sections; ZENAV_LOG."""

import argparse
import logging
import re
import sys
from pathlib import Path

import pytest

if sys.version_info >= (3, 11):
    import tomllib
else:  # Python 3.10
    import tomli as tomllib

from zenav import services
from zenav.cli.main import build_parser, main
from zenav.common import app
from zenav.common.config import OWN_SECTIONS, ConfigError, Settings, known_sections
from zenav.services.navigator.params import Params

DEFAULT_TOML = Path(__file__).resolve().parents[2] / "zenav" / "data" / "default.toml"


def options(add) -> set[str]:
    parser = argparse.ArgumentParser()
    add(parser)
    return {s for a in parser._actions for s in a.option_strings} - {"-h", "--help"}


def test_connection_and_deployment_options():
    assert options(app.connection_args) == {"--robot", "--connect", "--zenoh-mode"}
    assert options(app.deployment_args) == {"--robot", "--connect", "--zenoh-mode", "--config", "--scenario", "--seed", "--set"}


def test_unknown_section_is_an_error_naming_the_known_ones():
    with pytest.raises(ConfigError, match=re.escape("config: unknown section [nosuch] (known: deployment, robot, scenario")):
        Settings.load(None, nosuch={"key": 1})
    args = build_parser().parse_args(["up", "--set", "nosuch.key=1"])
    with pytest.raises(ConfigError, match=r"\[nosuch\]"):
        app.settings_from_args(args)


def test_unknown_section_in_a_file(tmp_path):
    path = tmp_path / "robot.toml"
    path.write_text("[navigator]\nmax_speed = 0.2\n[navigatr]\nmax_speed = 0.1\n")
    with pytest.raises(ConfigError, match=re.escape("unknown section [navigatr] (did you mean [navigator]? known: deployment,")):
        Settings.load(str(path))


def test_an_unknown_key_names_the_key_it_is_a_typo_of():
    with pytest.raises(
        ConfigError, match=re.escape("config [robot]: Object contains unknown field `track_widht` (did you mean `track_width`?)")
    ):
        Settings.load(None, robot={"track_widht": 0.1})
    with pytest.raises(
        ConfigError, match=re.escape("config [navigator]: Object contains unknown field `max_sped` (did you mean `max_speed`?)")
    ):
        Settings.load(None, navigator={"max_sped": 0.1}).section("navigator", Params)
    with pytest.raises(ConfigError) as e:
        Settings.load(None, navigator={"zzzz": 1}).section("navigator", Params)
    assert str(e.value) == "config [navigator]: Object contains unknown field `zzzz`"  # nothing near: no guess


def test_every_section_read_is_known():
    sections = set(known_sections())
    assert set(OWN_SECTIONS) <= sections and "camera" in sections and "driver" in sections
    assert {services.load(n).name for n in services.NAMES} <= sections
    assert sections == set(OWN_SECTIONS) | set(tomllib.loads(DEFAULT_TOML.read_text()))
    Settings.load(str(DEFAULT_TOML))  # every section documented loads


def test_zenav_up_refuses_an_unknown_section(capsys):
    assert main(["up", "--set", "nosuch.key=1", "--listen", "tcp/127.0.0.1:1"]) == 2
    err = capsys.readouterr().err
    assert "unknown section [nosuch]" in err and "navigator" in err


@pytest.mark.parametrize(
    "compose, words",
    [
        ("odometry,localizr", "compose: not a service: 'localizr'"),
        ("driver,motor", "--compose driver: not started by this run"),  # the sim profile runs no driver
    ],
)
def test_zenav_up_refuses_a_compose_it_cannot_do(compose, words, capsys):
    assert main(["up", "--compose", compose, "--listen", "tcp/127.0.0.1:1"]) == 2
    assert words in capsys.readouterr().err


@pytest.mark.parametrize("value, level", [("debug", logging.DEBUG), (" WARNING ", logging.WARNING), (None, logging.INFO)])
def test_zenav_log_sets_the_level(value, level, monkeypatch):
    if value is not None:
        monkeypatch.setenv("ZENAV_LOG", value)
    root = logging.getLogger()
    saved = root.level, list(root.handlers)
    root.handlers.clear()  # basicConfig configures only a root logger without handlers
    try:
        app.setup_logging()
        assert root.level == level
    finally:
        root.handlers[:] = saved[1]
        root.setLevel(saved[0])


def test_a_bad_zenav_log_is_a_config_error(monkeypatch):
    monkeypatch.setenv("ZENAV_LOG", "loud")
    with pytest.raises(ConfigError, match="ZENAV_LOG='LOUD': expected one of DEBUG, INFO, WARNING, ERROR"):
        app.setup_logging()


def test_zenav_log_is_in_the_help(capsys):
    with pytest.raises(SystemExit):
        main(["--help"])
    assert "ZENAV_LOG" in capsys.readouterr().out
    assert "ZENAV_LOG" in app.LOG_HELP


def test_a_service_with_a_bad_zenav_log_exits_2(monkeypatch, capsys):
    monkeypatch.setenv("ZENAV_LOG", "loud")
    assert app.main(services.load("motor"), ["--connect", "tcp/127.0.0.1:1"]) == 2  # before any connection
    assert capsys.readouterr().err == "zenav-motor: ZENAV_LOG='LOUD': expected one of DEBUG, INFO, WARNING, ERROR\n"
