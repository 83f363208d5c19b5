"""The one table of zenav's services and their roles; every list of services is derived from it.

Its order is the start order: launchers start the services one after the other without
waiting for any, and every service waits for its own inputs, so the order only decides
which process is spawned first (the world or the motor board, then the wheels, then the
chain from the sensors to the navigator). `stop` ranks the stop order, which matters for
safety: the navigator first (no new commands; the motor zeros the wheels when it sees the
navigator go), then the estimators, then the motor once the wheels were told zero, the
world or the board last (its wheels keep the last command they got; the driver sends
`m 0 0` as it stops).

This module imports nothing of zenav: the wire contract (`keys`), the config, the robot
library and the launchers all read it.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Role:
    """One service and what it is to the stack."""

    name: str
    target: str  # its Service class, "module:Class"
    stop: int  # stop rank: lower stops first
    profiles: tuple[str, ...]  # the `zenav up` profiles that run it
    control_loop: bool = False  # on the sensor-to-wheel path: `[deployment] realtime` raises its priority
    # its place on the sensor-to-wheel chain (0 first) with control on pose (`chain`); these run on the robot's own computer
    stage: int | None = None
    drive: bool = False  # a goal needs it alive (the robot library's wait_ready)
    essential: bool = False  # if it cannot run, the robot stops: `zenav up` commands zero and stops the stack


TABLE: tuple[Role, ...] = (  # in start order
    Role("driver", "zenav.services.driver.service:Driver", stop=5, profiles=("robot",), control_loop=True, essential=True),
    Role("sim", "zenav.services.sim.service:Sim", stop=5, profiles=("sim",)),
    Role(
        "motor",
        "zenav.services.motor.service:Motor",
        stop=4,
        profiles=("sim", "robot"),
        control_loop=True,
        stage=3,
        drive=True,
        essential=True,
    ),
    Role(
        "odometry",
        "zenav.services.odometry.service:Odometry",
        stop=3,
        profiles=("sim", "robot"),
        control_loop=True,
        stage=0,
        drive=True,
    ),
    Role("vps", "zenav.services.vps.service:Vps", stop=2, profiles=("sim",)),
    Role(
        "localizer",
        "zenav.services.localizer.service:Localizer",
        stop=1,
        profiles=("sim", "robot"),
        control_loop=True,
        stage=1,
        drive=True,
    ),
    Role(
        "navigator",
        "zenav.services.navigator.service:Navigator",
        stop=0,
        profiles=("sim", "robot"),
        control_loop=True,
        stage=2,
        drive=True,
        essential=True,
    ),
)

ALL: tuple[str, ...] = tuple(r.name for r in TABLE)  # every service, in start order
CONTROL_LOOP: tuple[str, ...] = tuple(r.name for r in TABLE if r.control_loop)
# the robot's own services, the chain's stages in its order (what `--compose` groups on a robot computer)
ROBOT_SERVICES: tuple[str, ...] = tuple(r.name for r in sorted((r for r in TABLE if r.stage is not None), key=lambda r: r.stage or 0))
DRIVE_SERVICES: tuple[str, ...] = tuple(r.name for r in TABLE if r.drive)
ESSENTIAL: tuple[str, ...] = tuple(r.name for r in TABLE if r.essential)
BY_NAME: dict[str, Role] = {r.name: r for r in TABLE}
CONTROL_ON: tuple[str, ...] = ("odom", "pose")  # what the navigator's control loop runs on: `[navigator] control_on`
OFF_CHAIN: dict[str, tuple[str, ...]] = {"odom": ("localizer",), "pose": ()}  # robot services off the chain, by control_on


def chain(control_on: str) -> tuple[str, ...]:
    """The services of the sensor-to-wheel chain in its order, the navigator's control loop on `control_on`: on odom
    the navigator reads the odometry's output, and the localizer's pose only corrects the samples after it."""
    return tuple(s for s in ROBOT_SERVICES if s not in OFF_CHAIN[control_on])


def start_order(control_on: str) -> tuple[str, ...]:
    """ALL, but a robot service off the chain after the others: in one process (`--compose`) a sample is then
    served by the chain's services first, as their subscriptions come first."""
    off = OFF_CHAIN[control_on]
    return tuple(s for s in ALL if s not in off) + off


def in_profile(profile: str) -> tuple[str, ...]:
    """The services a profile runs, in start order."""
    return tuple(r.name for r in TABLE if profile in r.profiles)
