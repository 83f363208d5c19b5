"""Configuration: one TOML file per deployment, a section per service.

Every key has a typed default in code (the service's Config struct); the file
overrides what it names, and `config/default.toml` documents every key (a test
keeps the two equal). A bad or unknown key fails fast, naming the key and the
accepted range: `config: [motor] watchdog: Expected `float` > 0.0`.
"""
from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass, field
from typing import Annotated, Any, Literal, Optional, TypeVar

import msgspec
from msgspec import Meta, Struct

from zenav.common import messages as m
from zenav.common.bus import DEFAULT_CONNECT
from zenav.common.scenarios import Scenario, scenario

T = TypeVar("T")


class ConfigError(ValueError):
    """A configuration value that is missing, unknown, of the wrong type or out of range."""


class Deployment(Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """Where and as what this stack runs (also from env and CLI)."""

    robot: Annotated[str, Meta(pattern=m.ROBOT_ID_PATTERN)] = "r1"  # key prefix zenav/<robot>/
    connect: str = DEFAULT_CONNECT  # Zenoh router endpoint(s), comma-separated
    zenoh_mode: Literal["client", "peer"] = "client"  # client: every message through the router; peer: services also link directly on loopback
    clock: Literal["sim", "wall"] = "sim"  # follow the sim's `clock` topic, or the host clock
    scenario: str = "default"  # scenario preset (default, coarse, harsh)
    seed: Annotated[int, Meta(ge=0)] = 1  # seed of the run's random generators


class Robot(Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """The robot's nominal geometry: what the stack believes, not what the world is."""

    wheel_diameter: Annotated[float, Meta(gt=0.0, le=10.0)] = 0.0673  # [m] 2.65 in
    track_width: Annotated[float, Meta(gt=0.0, le=10.0)] = 0.1156  # [m] wheel contact to contact
    ticks_per_rev: Optional[Annotated[int, Meta(ge=1, le=1_000_000)]] = None  # None: the scenario's
    max_wheel_speed: Annotated[float, Meta(gt=0.0, le=1e3)] = 10.0  # [rad/s]

    @property
    def wheel_radius(self) -> float:
        return self.wheel_diameter / 2.0


def _convert(raw: Any, typ: type[T], where: str) -> T:
    try:
        return msgspec.convert(raw, typ)
    except msgspec.ValidationError as e:
        text = re.sub(r"`\$\.?([^`]*)`", lambda g: f"`{where}.{g.group(1)}`".rstrip("."), str(e))
        raise ConfigError(f"config [{where}]: {text}") from None


@dataclass(frozen=True)
class Settings:
    """A loaded configuration: deployment values, robot, scenario, and raw sections."""

    deployment: Deployment
    robot: Robot
    scenario: Scenario
    sections: dict[str, dict] = field(default_factory=dict)
    path: Optional[str] = None

    @property
    def robot_id(self) -> str:
        return self.deployment.robot

    def section(self, name: str, typ: type[T]) -> T:
        """The typed config of one service; ConfigError names a bad key."""
        return _convert(self.sections.get(name, {}), typ, name)

    @classmethod
    def load(cls, path: Optional[str] = None, **overrides: dict) -> Settings:
        """Read `path` (or only defaults), then apply per-section overrides.

        `Settings.load(None, deployment={"robot": "r2"}, sim={"rtf": 5.0})`.
        """
        raw: dict[str, Any] = {}
        if path:
            try:
                with open(path, "rb") as f:
                    raw = tomllib.load(f)
            except (OSError, tomllib.TOMLDecodeError) as e:
                raise ConfigError(f"config {path}: {e}") from None
        for name, values in overrides.items():
            raw[name] = {**raw.get(name, {}), **{k: v for k, v in values.items() if v is not None}}
        for name, value in raw.items():
            if not isinstance(value, dict):
                raise ConfigError(f"config: `{name}` must be a [section], not a value")
        deployment = _convert(raw.get("deployment", {}), Deployment, "deployment")
        try:
            scen = scenario(deployment.scenario, raw.get("scenario"))
        except msgspec.ValidationError as e:
            raise ConfigError(f"config [scenario]: {e}") from None
        except ValueError as e:
            raise ConfigError(f"config [deployment] scenario: {e}") from None
        robot = _convert(raw.get("robot", {}), Robot, "robot")
        if robot.ticks_per_rev is None:  # the encoders are known: take the scenario's
            robot = msgspec.structs.replace(robot, ticks_per_rev=scen.ticks_per_rev)
        sections = {k: v for k, v in raw.items() if k not in ("deployment", "robot", "scenario")}
        return cls(deployment, robot, scen, sections, path)
