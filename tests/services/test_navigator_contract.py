"""Goals with extreme but legal values: every message the navigator publishes or replies stays inside the contract."""

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.support.fuzz import FUZZ
from tests.support.navigator import NavigatorRig, reply
from zenav.common import messages as m
from zenav.common.goalschema import SLOWEST as MIN_SPEED

TINY = 5e-324  # the smallest positive float
SPEEDS = st.sampled_from([TINY, 1e-300, 1e-14, 1e-4, MIN_SPEED * 0.999, MIN_SPEED, 0.01, 0.2, 1e3]) | st.floats(TINY, 1e3)
POSITIVE = st.none() | st.sampled_from([TINY, 1e-14, 1e-3, 0.01, 1e3]) | st.floats(TINY, 1e3)
COORD = st.sampled_from([-1e4, -1.0, 0.0, TINY, 0.5, 3.0, 1e4]) | st.floats(-1.0, 3.0)
ANGLE = st.sampled_from([-1e3, -3.2, 0.0, TINY, 1.0, 1e3]) | st.floats(-1e3, 1e3)
OPTIONS = {
    "speed": st.none() | SPEEDS,
    "tolerance": POSITIVE,
    "timeout": st.none() | st.sampled_from([TINY, 1e-9, 1.0, 1e4]),
    "min_speed": st.none() | st.sampled_from([0.0, TINY, 1e-3, 1e3]),
}
TURN = {"heading": ANGLE, "direction": st.sampled_from(["auto", "cw", "ccw"])}
GOALS = {
    "nav/move_to_point": {"x": COORD, "y": COORD, "forwards": st.booleans()},
    "nav/move_to_pose": {"x": COORD, "y": COORD, "theta": ANGLE, "heading_tolerance": POSITIVE, "lead": st.sampled_from([0.0, TINY, 1.0])},
    "nav/turn_to_heading": TURN,
    "nav/swing_to_heading": {**TURN, "side": st.sampled_from(["left", "right"])},
    "nav/turn_to_point": {"x": COORD, "y": COORD},
    "nav/follow_path": {"points": st.lists(st.tuples(COORD, COORD), min_size=1, max_size=4), "waypoint_tolerance": POSITIVE},
}


@st.composite
def goal(draw):
    """A goal query and its request: every field at a legal value, often the smallest or the largest."""
    suffix = draw(st.sampled_from([*GOALS, "nav/move_straight"]))
    if suffix == "nav/move_straight":
        speed = draw(SPEEDS) * draw(st.sampled_from([1.0, -1.0]))
        return suffix, {"speed": speed, "distance": draw(st.none() | st.sampled_from([TINY, 1e-3, 0.3, 1e4]))}
    fields = {**OPTIONS, **GOALS[suffix]}
    return suffix, {k: v for k, v in draw(st.fixed_dictionaries(fields)).items() if v is not None}


@settings(FUZZ, max_examples=300)
@given(goal())
def test_nav_state_stays_inside_the_contract_whatever_legal_goal_runs(sent):
    suffix, request = sent
    rig = NavigatorRig()
    try:
        rig.pose()
        q = rig.query(suffix, request)
        rig.step(30)  # 0.3 s: the goal's first commands, its 5 Hz state and any early end
        states = rig.published("nav/state")  # decoded against the contract: a value out of it raises here
        assert states and all(s.eta is None or 0.0 <= s.eta <= 1e12 for s in states)
        assert isinstance(reply(rig.query("nav/status"), m.StatusReply), m.StatusReply)
        rep = reply(q)
        speed = request.get("speed")
        if speed is not None and abs(speed) < MIN_SPEED:
            assert rep.error == "invalid_argument", rep  # this, or another field's error
    finally:
        rig.nav.close()


@pytest.mark.parametrize("speed", [5e-324, 1e-14, 9.99e-4])
@pytest.mark.parametrize(
    ("suffix", "request_", "unit", "sign"),
    [
        ("nav/move_to_point", {"x": 1.0, "y": 0.0}, "m/s", 1.0),
        ("nav/follow_path", {"points": [[1.0, 0.0]]}, "m/s", 1.0),
        ("nav/move_straight", {"distance": 0.5}, "m/s", -1.0),
        ("nav/turn_to_heading", {"heading": 1.0}, "rad/s", 1.0),
    ],
)
def test_a_speed_under_the_slowest_is_refused_naming_the_bound(suffix, request_, unit, sign, speed):
    speed *= sign  # move_straight's is signed
    rig = NavigatorRig()
    try:
        rig.pose()
        err = reply(rig.query(suffix, {**request_, "speed": speed}))
        assert err.error == "invalid_argument" and err.message == (
            f"speed: {speed:g} {unit} is under the slowest a goal drives, {MIN_SPEED:g} {unit}"
        ), err
        assert rig.nav.machine.goal_id == 0
    finally:
        rig.nav.close()
