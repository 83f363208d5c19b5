"""The zenav services, one package each: <algorithm>.py pure cores, service.py wiring.

`REGISTRY` is the one list of them. Its order is the start order: launchers start
the services one after the other without waiting for any, and every service waits
for its own inputs, so the order only decides which process is spawned first (the
world or the motor board, then the wheels, then the chain from the sensors to the
navigator). `stop` ranks the stop order, which matters for safety: the navigator
first (no new commands; the motor zeros the wheels when it sees the navigator go, and
`zenav up` also publishes a zero command), then the estimators, then the motor once
the wheels were told zero, the world or the board last (its wheels keep the last
command they got; the driver sends `m 0 0` as it stops).

`PROFILES` names what runs together: `sim` (the default) the simulated robot seen by
its overhead camera, `robot` a real one through the driver, on the host's wall clock.
"""

from __future__ import annotations

import importlib
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

from zenav.common.runtime import Service


@dataclass(frozen=True)
class Entry:
    """One service: its name, its Service class as "module:Class", its place in the stop order."""

    name: str
    target: str
    stop: int  # stop rank: lower stops first


REGISTRY: tuple[Entry, ...] = (  # in start order
    Entry("driver", "zenav.services.driver.service:Driver", stop=5),
    Entry("sim", "zenav.services.sim.service:Sim", stop=5),
    Entry("motor", "zenav.services.motor.service:Motor", stop=4),
    Entry("odometry", "zenav.services.odometry.service:Odometry", stop=3),
    Entry("vps", "zenav.services.vps.service:Vps", stop=2),
    Entry("localizer", "zenav.services.localizer.service:Localizer", stop=1),
    Entry("navigator", "zenav.services.navigator.service:Navigator", stop=0),
)
ALL: tuple[str, ...] = tuple(e.name for e in REGISTRY)  # every service, in start order
_BY_NAME = {e.name: e for e in REGISTRY}


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


def _ordered(names: Iterable[str]) -> tuple[str, ...]:
    wanted = set(names)
    return tuple(n for n in ALL if n in wanted)


DEFAULT_PROFILE = "sim"
PROFILES: dict[str, Profile] = {
    # The simulated robot: the sim owns the clock and renders the overhead camera's frames,
    # the vps reads the robot's tag in them (docker-compose.yml sets the same). The synthetic
    # VPS (the truth plus the scenario's errors, no pixels): --set vps.source=synthetic, and
    # where OpenCV is not installed (the base install: `zenav up` says so).
    "sim": Profile(
        _ordered(("sim", "motor", "odometry", "vps", "localizer", "navigator")),
        camera={"sim": {"camera": True}, "vps": {"source": "camera"}},
    ),
    # A real robot: the driver instead of the sim; every service on the host's clock
    # (it overrides the config file; the rest, e.g. [odometry] heading_source, is the
    # robot's config file's); no vps (add it with --services when a camera VPS runs on
    # this host; else `zenav set-pose` places the robot). No demo square here.
    "robot": Profile(
        _ordered(("driver", "motor", "odometry", "localizer", "navigator")),
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
    return sorted(names, key=lambda n: _BY_NAME[n].stop)


def load(name: str) -> type[Service]:
    """The Service class of a service name (KeyError if there is none)."""
    module, cls = _BY_NAME[name].target.split(":")
    return getattr(importlib.import_module(module), cls)
