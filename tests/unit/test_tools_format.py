"""The recording format: topics, keys, and a self-contained JSON Schema per message type."""

from __future__ import annotations

import json

import msgspec
import pytest

from zenav.common import keys
from zenav.common import messages as m
from zenav.tools import mcap_format as fmt


def test_topics_are_the_zenoh_keys_with_a_leading_slash():
    assert fmt.topic_of("zenav/r1/odom") == "/zenav/r1/odom"
    assert fmt.key_of("/zenav/r1/diag/sim") == "zenav/r1/diag/sim"
    assert fmt.contract_topic("zenav/r1/localizer/fixes") == ("r1", "localizer/fixes", m.Fix)
    assert fmt.contract_topic("zenav/r1/alive/sim") is None


def walk(node):
    yield node
    if isinstance(node, dict):
        for v in node.values():
            yield from walk(v)
    elif isinstance(node, list):
        for v in node:
            yield from walk(v)


@pytest.mark.parametrize("typ", sorted(set(keys.TOPICS.values()), key=lambda t: t.__name__))
def test_every_message_type_has_a_flat_object_schema(typ):
    schema = fmt.json_schema(typ)
    assert schema["type"] == "object" and schema["title"] == f"zenav.{typ.__name__}"
    assert set(schema["properties"]) == set(typ.__struct_fields__)
    for node in walk(schema):  # one plain `type` per field, nothing to resolve
        assert not (isinstance(node, dict) and ({"$ref", "$defs", "anyOf"} & set(node)))
    for name, prop in schema["properties"].items():
        assert prop["type"] in ("number", "integer", "string", "boolean", "array", "object"), name
    assert json.loads(fmt.schema_bytes(typ)) == json.loads(json.dumps(schema))


def test_optional_fields_keep_their_type_and_bounds():
    props = fmt.json_schema(m.NavState)["properties"]
    assert props["distance_remaining"]["type"] == "number" and props["distance_remaining"]["default"] is None
    assert props["goal"]["type"] == "object"
    pose = fmt.json_schema(m.Pose)["properties"]
    assert pose["cov"]["minItems"] == pose["cov"]["maxItems"] == 9
    assert pose["x"]["minimum"] == -1e4


def test_json_round_trip_and_stamps():
    msg = m.Pose(t=12.345678901, x=1.0, y=-2.0, theta=0.5, v=0.1, omega=0.0, calibration={"k": 1.5})
    assert msgspec.json.decode(fmt.to_json(msg), type=m.Pose) == msg
    assert fmt.stamp(12.345678901) == 12_345_678_901
    assert fmt.stamp(0.0) == 0
