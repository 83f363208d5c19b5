"""The goal schema (common/goalschema.py) is the one declaration of the goals: the navigator's intake and queries,
the robot library's methods (sync and asyncio) and the CLI's goal commands are checked against it here, and
docs/contract.md's goal tables by tests/unit/test_contract_doc.py."""

import argparse
import inspect

import pytest

from zenav import aio, goalapi, robot
from zenav.cli import nav
from zenav.common import keys
from zenav.common import messages as m
from zenav.common.app import connection_args
from zenav.common.contract import State
from zenav.common.goalschema import GOALS, LIBRARY_MANAGED, request
from zenav.services.navigator import intake
from zenav.services.navigator.service import Navigator


@pytest.mark.parametrize("spec", GOALS.values(), ids=lambda s: s.name)
def test_the_library_method_takes_the_goal_s_fields_with_their_defaults(spec):
    params = list(inspect.signature(getattr(goalapi.GoalMethods, spec.name)).parameters.values())[1:]  # after self
    fields = [f for f in spec.fields if f.name not in LIBRARY_MANAGED]
    assert sorted(p.name for p in params) == sorted(f.name for f in fields), spec.name
    positional = [p.name for p in params if p.kind is p.POSITIONAL_OR_KEYWORD]
    assert positional == [f.name for f in fields if f.required], f"{spec.name}: the required fields, in order, are positional"
    by_name = {p.name: p for p in params}
    for f in fields:
        if not f.required:
            assert by_name[f.name].kind is inspect.Parameter.KEYWORD_ONLY and by_name[f.name].default == f.default, f.name


def test_both_robots_take_their_goal_methods_from_the_one_declaration():
    for name in GOALS:
        assert getattr(robot.Robot, name) is getattr(aio.AsyncRobot, name) is getattr(goalapi.GoalMethods, name)


def test_a_request_sends_what_differs_from_the_defaults_and_refuses_a_name_that_is_no_field():
    spec = GOALS["turn_to_point"]
    sent = request(spec, {"self": object(), "x": 1.0, "y": 0.0, "speed": None, "forwards": True, "direction": "cw", "timeout": 2.0})
    assert sent == {"x": 1.0, "y": 0.0, "direction": "cw", "timeout": 2.0}
    assert request(spec, {"x": 1.0, "y": 0.0, "forwards": False})["forwards"] is False
    with pytest.raises(TypeError, match="turn_to_point: no field heading"):
        request(spec, {"x": 1.0, "y": 0.0, "heading": 1.0})


def test_every_goal_is_a_query_of_the_navigator_with_its_request_and_an_intake():
    served = {fn._zenav_query.suffix for fn in vars(Navigator).values() if hasattr(fn, "_zenav_query")}
    for spec in GOALS.values():
        assert keys.QUERIES[spec.key] == (spec.request, m.GoalReply), spec.key
        assert callable(getattr(intake, spec.name)), f"navigator intake has no {spec.name}"
        assert spec.key in served, f"the navigator serves no {spec.key}"
    assert {s.state for s in GOALS.values()} == set(State) - {State.STOPPED}


def test_the_schema_has_each_field_s_unit_and_bounds():
    speed = GOALS["turn_to_heading"].field("speed")
    assert (speed.unit, speed.low, speed.low_open, speed.required, speed.default) == ("rad/s", 0.0, True, False, None)
    assert GOALS["move_to_point"].field("speed").unit == "m/s" and GOALS["move_to_pose"].field("lead").high == 1.0
    assert GOALS["swing_to_heading"].field("side").choices == ("left", "right")
    with pytest.raises(KeyError):
        GOALS["move_straight"].field("tolerance")


def cli_commands() -> dict[str, argparse.ArgumentParser]:
    parser = argparse.ArgumentParser()
    nav.add_arguments(parser.add_subparsers())
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return {cmd: sub.choices[cmd] for cmd in nav.COMMANDS}


@pytest.mark.parametrize("command", nav.COMMANDS)
def test_a_cli_goal_command_s_options_are_fields_of_its_goal(command):
    spec, parser = GOALS[nav.COMMANDS[command]], cli_commands()[command]
    bare = argparse.ArgumentParser()
    connection_args(bare)
    own = {a.dest for a in bare._actions} | set(nav.OWN)
    options = [a for a in parser._actions if a.dest not in own]
    assert parser.get_default("query") == spec.key
    for a in options:
        f = spec.field(nav.RENAMED.get(a.dest, a.dest))  # KeyError: an option that is no field of the goal
        if f.choices:
            assert tuple(a.choices) == f.choices, a.dest
    assert {f.name for f in spec.fields if f.required} <= {nav.RENAMED.get(a.dest, a.dest) for a in options}
