"""The zenav services, one package each: <algorithm>.py pure cores, service.py wiring.

Which services there are, their start and stop order and their roles are the one table
in `zenav.common.roles`. Here: the profiles (`PROFILES`: what runs together, with which
config: `sim`, the default, the simulated robot seen by its overhead camera; `robot`, a
real one through the driver, on the host's wall clock) and loading a service's class.
"""

from __future__ import annotations

import importlib
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any, cast

from zenav.common import roles
from zenav.common.runtime import Service

ALL: tuple[str, ...] = roles.ALL  # every service, in start order


@dataclass(frozen=True)
class Profile:
    """A deployment: the services it runs and the config it sets (under the user's --set)."""

    services: tuple[str, ...]  # in start order
    settings: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)  # section -> key -> value
    demo: bool = True  # `zenav up --demo` may drive its square here
    camera: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)  # settings beside those where OpenCV is installed

    def sets(self, camera: bool = True) -> list[str]:
        """The settings as --set items (SECTION.KEY=VALUE, the value in TOML syntax); the camera's too if `camera`."""
        chosen = [*self.settings.items(), *(self.camera.items() if camera else ())]
        return [f"{s}.{k}={_toml(v)}" for s, values in chosen for k, v in values.items()]


def _toml(value: Any) -> str:
    """A scalar as a TOML value."""
    if isinstance(value, bool):
        return "true" if value else "false"
    return f'"{value}"' if isinstance(value, str) else repr(value)


DEFAULT_PROFILE = "sim"
PROFILES: dict[str, Profile] = {
    # The simulated robot: the sim owns the clock and renders the overhead camera's frames,
    # the vps reads the robot's tag in them (docker-compose.yml sets the same). The synthetic
    # VPS (the truth plus the scenario's errors, no pixels): --set vps.source=synthetic, and
    # where OpenCV is not installed (the base install: `zenav up` says so).
    "sim": Profile(
        roles.in_profile("sim"),
        camera={"sim": {"camera": True}, "vps": {"source": "camera"}},
    ),
    # A real robot: the driver instead of the sim; every service on the host's clock
    # (it overrides the config file; the rest, e.g. [odometry] heading_source, is the
    # robot's config file's); no vps (add it with --services when a camera VPS runs on
    # this host; else `zenav set-pose` places the robot). No demo square here.
    "robot": Profile(
        roles.in_profile("robot"),
        {"deployment": {"clock": "wall"}},
        demo=False,
    ),
}
NAMES: tuple[str, ...] = PROFILES[DEFAULT_PROFILE].services  # the default stack, in start order


def running(alive: Iterable[str]) -> tuple[str, ...]:
    """The services of the profile that runs, judged by the services `alive`: the one whose
    world (its first service: the sim, the board's driver) is alive, else the default."""
    up = set(alive)
    world = [p for p in PROFILES.values() if p.services[0] in up]
    return (world[0] if world else PROFILES[DEFAULT_PROFILE]).services


def stop_order(names: Iterable[str] = NAMES) -> list[str]:
    """`names` in the order they must stop (the navigator first, the world or the board last)."""
    return sorted(names, key=lambda n: roles.BY_NAME[n].stop)


def load(name: str) -> type[Service]:
    """The Service class of a service name (KeyError if there is none)."""
    module, cls = roles.BY_NAME[name].target.split(":")
    return cast(type[Service], getattr(importlib.import_module(module), cls))
