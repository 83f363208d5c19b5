"""The navigator's goals, declared once: each goal's query, request message, state, and its fields' units, bounds
and defaults.

The request messages (common/messages.py) hold each field's type, bounds and default, which the navigator enforces
by decoding; this table adds what a message cannot say: the goal's name and state, whether it turns (its speeds
in rad/s, its tolerances in rad), each field's unit, and the slowest speed a goal drives. The navigator's intake,
the robot library's goal methods (sync and asyncio), the CLI's options and docs/contract.md's goal tables are
built from it or checked against it by tests.
"""

from __future__ import annotations

import functools
import typing
from dataclasses import dataclass
from typing import Any

import msgspec.inspect as mi

from zenav.common import messages as m
from zenav.common.contract import State

# [m/s] ([rad/s] for turns) the slowest speed a goal may ask for: 1 mm/s. Slower is no drive at all (a 1 m goal at
# 1e-14 m/s would end after 3 million years: its eta would leave the contract's range); refused naming this bound.
SLOWEST = 1e-3
LIBRARY_MANAGED = ("wait", "lease")  # fields the robot library sets itself: a goal's handle waits; its lease is the robot's

# Each field's unit: (in a goal that drives, in a turn). "": none.
UNITS: dict[str, tuple[str, str]] = {
    "x": ("m", "m"),
    "y": ("m", "m"),
    "theta": ("rad", "rad"),
    "heading": ("rad", "rad"),
    "points": ("m", "m"),
    "speed": ("m/s", "rad/s"),
    "tolerance": ("m", "rad"),
    "heading_tolerance": ("rad", "rad"),
    "waypoint_tolerance": ("m", "m"),
    "distance": ("m", "m"),
    "timeout": ("s", "s"),
    "min_speed": ("m/s", "rad/s"),
    "early_exit_range": ("m", "rad"),
}


@dataclass(frozen=True)
class FieldSpec:
    """One field of a goal request."""

    name: str
    required: bool
    default: Any  # None where the navigator's config decides; unset (mi.NODEFAULT) for a required field
    unit: str  # "" for none
    choices: tuple[str, ...] = ()  # the values a text field takes; (): any
    low: float | None = None  # the least value (`low_open`: excluded); None: no bound
    low_open: bool = False
    high: float | None = None  # the greatest value; None: no bound


@dataclass(frozen=True)
class GoalSpec:
    """One goal: its name (the query nav/<name>, the `type` of nav/state's goal map), request, state and kind."""

    name: str
    request: type[m.Request]
    state: State
    turn: bool = False  # speeds in rad/s, tolerances in rad

    @property
    def key(self) -> str:
        """The goal's query suffix."""
        return f"nav/{self.name}"

    @functools.cached_property
    def fields(self) -> tuple[FieldSpec, ...]:
        """The request's fields, in the message's order."""
        info = mi.type_info(self.request)
        assert isinstance(info, mi.StructType)  # a request is a struct
        hints = typing.get_type_hints(self.request)  # a Literal's values in their declared order (msgspec sorts them)
        return tuple(_field(f, self.turn, hints[f.name]) for f in info.fields)

    def field(self, name: str) -> FieldSpec:
        """One field by name (KeyError if the goal has none)."""
        found = next((f for f in self.fields if f.name == name), None)
        if found is None:
            raise KeyError(f"{self.name} has no field {name!r}")
        return found


GOALS: dict[str, GoalSpec] = {
    spec.name: spec
    for spec in (
        GoalSpec("move_to_point", m.MoveToPoint, State.MOVING_TO_POINT),
        GoalSpec("move_to_pose", m.MoveToPose, State.MOVING_TO_POSE),
        GoalSpec("turn_to_heading", m.TurnToHeading, State.TURNING_TO_HEADING, turn=True),
        GoalSpec("turn_to_point", m.TurnToPoint, State.TURNING_TO_HEADING, turn=True),
        GoalSpec("swing_to_heading", m.SwingToHeading, State.TURNING_TO_HEADING, turn=True),
        GoalSpec("move_straight", m.MoveStraight, State.MOVING_STRAIGHT),
        GoalSpec("follow_path", m.FollowPath, State.FOLLOWING_PATH),
    )
}


def _field(f: mi.Field, turn: bool, hint: Any) -> FieldSpec:
    types = f.type.types if isinstance(f.type, mi.UnionType) else (f.type,)
    choices = tuple(map(str, typing.get_args(hint))) if typing.get_origin(hint) is typing.Literal else ()
    num = next((t for t in types if isinstance(t, mi.FloatType)), None)
    low = None if num is None else num.ge if num.ge is not None else num.gt
    high = None if num is None else num.le
    unit = UNITS.get(f.name, ("", ""))[turn]
    return FieldSpec(f.name, f.required, f.default, unit, choices, low, num is not None and num.gt is not None, high)


def request(spec: GoalSpec, values: dict[str, Any]) -> dict[str, Any]:
    """A goal's request from a library method's arguments (`locals()`: `self` left out): each field sent only when it
    differs from the default, so a navigator that predates a field takes every goal that does not ask for it.
    TypeError on a name that is not a field."""
    values = {k: v for k, v in values.items() if k not in ("self", "__class__")}
    unknown = sorted(set(values) - {f.name for f in spec.fields})
    if unknown:
        raise TypeError(f"{spec.name}: no field {', '.join(unknown)}")
    out = {}
    for f in spec.fields:
        value = values.get(f.name)
        if f.name in values and (f.required or value != f.default):
            out[f.name] = value
    return out
