"""zenav/data/foxglove-layout.json names only topics and fields that `zenav view` and `zenav record` provide."""

from __future__ import annotations

import json
import re
from pathlib import Path

from zenav.common import keys
from zenav.tools.view import VIZ_CHANNELS

LAYOUT = Path(__file__).resolve().parents[2] / "zenav" / "data" / "foxglove-layout.json"


def strings(node):
    if isinstance(node, str):
        yield node
    elif isinstance(node, dict):
        for k, v in node.items():
            yield k
            yield from strings(v)
    elif isinstance(node, list):
        for v in node:
            yield from strings(v)


def panels(tree):
    if isinstance(tree, str):
        return {tree}
    return panels(tree["first"]) | panels(tree["second"])


def test_every_panel_is_placed_and_configured():
    layout = json.loads(LAYOUT.read_text())
    assert panels(layout["layout"]) == set(layout["configById"])


def test_every_topic_and_field_exists():
    layout = json.loads(LAYOUT.read_text())
    paths = {s for s in strings(layout["configById"]) if s.startswith("/zenav/")}
    assert paths
    for path in paths:
        robot, rest = re.match(r"^/zenav/([^/]+)/(.*)$", path).groups()
        assert robot == "r1"
        if rest in VIZ_CHANNELS:
            continue
        topic = max((t for t in keys.TOPICS if rest == t or rest.startswith(t + ".")), key=len, default=None)
        assert topic is not None, path
        field = rest[len(topic) + 1 :]
        if field:
            name = re.match(r"^(\w+)", field).group(1)
            assert name in keys.TOPICS[topic].__struct_fields__, path
