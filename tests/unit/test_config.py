"""Configuration: defaults in code, documented in zenav/data/default.toml, bad values fail fast."""

import re
from importlib.resources import files
from pathlib import Path

import msgspec
import pytest

from zenav import services
from zenav.common.app import parse_sets
from zenav.common.config import RENAMED_KEYS, RENAMED_VALUES, Camera, ConfigError, Deployment, RobotConfig, Settings
from zenav.common.keys import SERVICES
from zenav.common.onboardcam import OnboardCamera
from zenav.common.scenarios import PRESETS, Scenario

DEFAULT_TOML = Path(__file__).resolve().parents[2] / "zenav" / "data" / "default.toml"
SECTION_TYPES = {
    "deployment": Deployment,
    "robot": RobotConfig,
    "camera": Camera,
    "onboard_camera": OnboardCamera,
    **{n: services.load(n).config_type for n in SERVICES},
}


def documented_keys(text: str) -> dict[str, set[str]]:
    """section -> keys that have a `#` comment on their own line or the line above."""
    out, section, prev = {}, None, ""
    for line in text.splitlines():
        s = line.strip()
        head = re.match(r"^\[([\w.]+)\]", s)
        if head:
            section = head.group(1)
            out.setdefault(section, set())
        kv = re.match(r"^#?\s*([A-Za-z_]\w*)\s*=", s)  # `# key = v`: an optional key, documented
        if kv and section and ("#" in s or prev.startswith("#")):
            out[section].add(kv.group(1))
        prev = s
    return out


def test_default_toml_documents_every_key_with_the_code_default():
    text = DEFAULT_TOML.read_text()
    doc = documented_keys(text)
    settings = Settings.load(str(DEFAULT_TOML))
    for section, typ in SECTION_TYPES.items():
        if typ is None:
            continue
        fields = {f.encode_name for f in msgspec.inspect.type_info(typ).fields}
        assert fields <= doc.get(section, set()), f"[{section}] undocumented: {fields - doc.get(section, set())}"
        if section not in ("deployment", "robot"):
            assert settings.section(section, typ) == typ(), f"[{section}] in default.toml differs from the code"


def test_default_toml_loads_the_default_scenario():
    settings = Settings.load(str(DEFAULT_TOML))
    assert settings.scenario == PRESETS["default"] and settings.robot.ticks_per_rev == 360


def test_scenario_presets_and_overrides():
    s = Settings.load(None, deployment={"scenario": "harsh"}, scenario={"vps_drop": 0.5})
    assert s.scenario.vps_drop == 0.5 and s.scenario.track_width_err == 0.04
    assert s.robot.ticks_per_rev == 16  # the stack is configured with the encoders it has
    assert Settings.load(None, robot={"ticks_per_rev": 1024}).robot.ticks_per_rev == 1024


@pytest.mark.parametrize(
    "overrides, words",
    [
        ({"deployment": {"scenario": "stormy"}}, "stormy"),
        ({"deployment": {"robot": "r/1"}}, "deployment.robot"),
        ({"robot": {"wheel_diameter": -1.0}}, "robot.wheel_diameter"),
        ({"robot": {"whee_diameter": 0.1}}, "whee_diameter"),
        ({"scenario": {"vps_drop": 2.0}}, "vps_drop"),
        ({"deployment": {"compose": ["odometry", "localizr"]}}, "not a service: 'localizr'"),
        ({"deployment": {"compose": "odometry"}}, "deployment.compose"),
    ],
)
def test_bad_values_name_the_key(overrides, words):
    with pytest.raises(ConfigError, match=re.escape(words)):
        Settings.load(None, **overrides)


def test_compose_names_services():
    assert Settings.load(None).deployment.compose == ()
    s = Settings.load(None, deployment={"compose": ["odometry", "localizer", "navigator", "motor"]})
    assert s.deployment.compose == ("odometry", "localizer", "navigator", "motor")


@pytest.mark.parametrize("name", [n for n in SERVICES if services.load(n).config_type is not None])
def test_service_sections_refuse_unknown_keys(name):
    typ = services.load(name).config_type
    with pytest.raises(ConfigError, match=rf"\[{name}\].*no_such_key"):
        Settings.load(None, **{name: {"no_such_key": 1}}).section(name, typ)


def test_a_retired_key_says_what_became_of_it():
    typ = services.load("vps").config_type
    with pytest.raises(ConfigError, match=r"\[vps\]: `delivery_period` is no longer a setting: each fix is sent at its delivery time"):
        Settings.load(None, vps={"delivery_period": 0.005}).section("vps", typ)


OLD_MODES = [("seed001", "estimate_average"), ("multisensor", "complementary"), ("weighted", "speed_weighted")]


@pytest.mark.parametrize(("old", "new"), OLD_MODES)
def test_a_config_file_with_an_old_mode_name_still_loads_and_says_the_new_one(tmp_path, caplog, old, new):
    p = tmp_path / "old.toml"
    p.write_text(f'[localizer]\nmode = "{old}"\nseed001_fix_weight = 0.2\n')
    with caplog.at_level("WARNING", logger="zenav"):
        cfg = Settings.load(str(p)).section("localizer", services.load("localizer").config_type)
    assert cfg.mode == new and cfg.estimate_average_fix_weight == 0.2
    lines = [r.getMessage() for r in caplog.records]
    assert [line for line in lines if f'"{old}" is now called "{new}"' in line] != []
    assert len([line for line in lines if "`seed001_fix_weight` is now called `estimate_average_fix_weight`" in line]) == 1


def test_an_old_key_and_its_new_name_together_are_refused():
    with pytest.raises(ConfigError, match=r"`multisensor_fix_weight` is the old name of `complementary_fix_weight`, and both are set"):
        Settings.load(None, localizer={"multisensor_fix_weight": 0.1, "complementary_fix_weight": 0.2})


def test_every_renamed_name_leads_to_a_setting_that_exists():
    for (section, _old), new in RENAMED_KEYS.items():
        assert new in {f.name for f in msgspec.structs.fields(SECTION_TYPES[section])}
    for (section, key, _old), new in RENAMED_VALUES.items():
        assert Settings.load(None, **{section: {key: new}}).section(section, SECTION_TYPES[section])


def test_bad_file_is_a_config_error(tmp_path):
    p = tmp_path / "bad.toml"
    p.write_text("[sim\nrtf = 1")
    with pytest.raises(ConfigError, match="bad.toml"):
        Settings.load(str(p))
    with pytest.raises(ConfigError, match="missing.toml"):
        Settings.load(str(tmp_path / "missing.toml"))


def test_set_overrides_parse_toml_values():
    assert parse_sets(["sim.rtf=5", "odometry.integrator=arc", "vps.enabled=false"]) == {
        "sim": {"rtf": 5},
        "odometry": {"integrator": "arc"},
        "vps": {"enabled": False},
    }
    with pytest.raises(ConfigError, match="SECTION.KEY=VALUE"):
        parse_sets(["rtf=5"])


def test_scenario_is_typed():
    with pytest.raises(msgspec.ValidationError):
        msgspec.convert({"ticks_per_rev": 0}, Scenario)


@pytest.mark.parametrize("name", ["default.toml", "foxglove-layout.json"])
def test_the_package_ships_its_data_files(name):
    assert (files("zenav") / "data" / name).read_text().strip()


@pytest.mark.parametrize(
    "values, words",
    [({"pid_gains": [20, 12, 0, 0]}, "pid_gains"), ({"baud": 12}, "baud"), ({"sensor_rate": 0.0}, "sensor_rate")],
)
def test_driver_section_refuses_bad_values(values, words):
    typ = services.load("driver").config_type
    with pytest.raises(ConfigError, match=rf"\[driver\].*{words}"):
        Settings.load(None, driver=values).section("driver", typ)


def test_the_navigators_old_min_speed_key_is_its_crawl_speed(caplog):
    typ = services.load("navigator").config_type
    with caplog.at_level("WARNING", logger="zenav"):
        cfg = Settings.load(None, navigator={"min_speed": 0.05}).section("navigator", typ)
    assert cfg.crawl_speed == 0.05
    assert any("`min_speed` is now called `crawl_speed`" in r.getMessage() for r in caplog.records)
