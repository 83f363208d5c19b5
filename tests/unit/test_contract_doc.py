"""docs/contract.md says what the code does: every key, message, field, type and default.

The doc's tables are read as data: under `## Topics` (keys under `zenav/<robot>/`) and
`## Field topics` (under `zenav/field/`) one row per key (key, message),
under `## Queries` one row per key (key, request, reply), under `## Services` one row
per service (name, liveliness token, diag topic), and under `## Messages` one
`### <Name>` section per message type with one row per field
(field, type, default, unit, meaning). A key, message or field added to the code
makes these tests fail with the row to add.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import msgspec.inspect as mi
import pytest

from zenav.common import keys
from zenav.common import messages as m
from zenav.common.contract import ErrorCode, Exit, GoalResult, Reason, State
from zenav.common.goalschema import GOALS, SLOWEST

DOC = Path(__file__).resolve().parents[2] / "docs" / "contract.md"
PER_SERVICE = "<service>"


def cells(line: str) -> list[str]:
    """The cells of one markdown table row, stripped."""
    return [c.strip() for c in line.strip().strip("|").split("|")]


def tables(text: str) -> dict[str, list[list[str]]]:
    """Table rows (header and separator left out) by the heading above them, hashes included (`## Topics`)."""
    out: dict[str, list[list[str]]] = {}
    heading, header_seen = "", False
    for line in text.splitlines():
        if line.startswith("#"):
            heading, header_seen = line.strip(), False
            out.setdefault(heading, [])  # a message without fields has a section all the same
        elif line.startswith("|"):
            if not header_seen:
                header_seen = True  # the header row
            elif not set(line) <= set("|-: "):  # not the separator
                out.setdefault(heading, []).append(cells(line))
    return out


def column(text: str, header: str) -> list[str]:
    """The first column's codes of the table whose header row starts with `header` (`| exit |`)."""
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("|") and cells(line)[0] == header)
    rows = []
    for line in lines[start + 2 :]:  # past the header and the separator
        if not line.startswith("|"):
            break
        rows.append(code(cells(line)[0]))
    return rows


def code(cell: str) -> str:
    """The first `code` span of a cell (`Odom` in [`Odom`](#odom))."""
    found = re.search(r"`([^`]*)`", cell)
    return found.group(1) if found else cell


def type_text(t: mi.Type) -> str:
    """How the doc writes a field's type."""
    if isinstance(t, mi.UnionType):
        return " or ".join(type_text(u) for u in t.types)
    if isinstance(t, (mi.ListType, mi.VarTupleType)):
        if t.min_length is not None and t.min_length == t.max_length:
            return f"{type_text(t.item_type)}[{t.min_length}]"
        return f"array of {type_text(t.item_type)}"
    if isinstance(t, mi.DictType):
        return f"map {type_text(t.key_type)} -> {type_text(t.value_type)}"
    if isinstance(t, mi.StructType):
        return t.cls.__name__
    if isinstance(t, mi.LiteralType):
        return " or ".join(json.dumps(v) for v in sorted(t.values, key=str))
    names = {
        mi.FloatType: "float",
        mi.IntType: "int",
        mi.StrType: "str",
        mi.BoolType: "bool",
        mi.BytesType: "bin",
        mi.NoneType: "nil",
        mi.AnyType: "any",
    }
    return names[type(t)]


def default_text(f: mi.Field) -> str:
    """How the doc writes a field's default: `required`, or the value as msgpack would carry it."""
    if f.required:
        return "required"
    value = f.default if f.default is not mi.NODEFAULT else f.default_factory()
    if isinstance(value, (tuple, list)) and len(value) > 3 and len(set(value)) == 1:
        return f"{len(value)} x {json.dumps(value[0])}"
    return "nil" if value is None else json.dumps(list(value) if isinstance(value, tuple) else value)


def field_row(f: mi.Field) -> str:
    return f"| `{f.encode_name}` | {type_text(f.type)} | {default_text(f)} | <unit> | <meaning> |"


def message_types() -> list[type]:
    """Every message on the wire: topic messages, requests, replies, errors and what they contain."""
    found: dict[type, None] = {}

    def visit(t: mi.Type) -> None:
        if isinstance(t, mi.StructType) and t.cls not in found:
            found[t.cls] = None
            for f in t.fields:
                visit(f.type)
        elif isinstance(t, mi.UnionType):
            for u in t.types:
                visit(u)
        elif isinstance(t, (mi.ListType, mi.VarTupleType)):
            visit(t.item_type)
        elif isinstance(t, mi.DictType):
            visit(t.value_type)

    roots = [*keys.TOPICS.values(), *keys.FIELD_TOPICS.values(), *(t for pair in keys.QUERIES.values() for t in pair), m.ErrorReply]
    for typ in roots:
        visit(mi.type_info(typ))
    return list(found)


@pytest.fixture(scope="module")
def doc() -> dict[str, list[list[str]]]:
    return tables(DOC.read_text())


def expand(key: str) -> list[str]:
    """A documented key: `diag/<service>` stands for one key per service."""
    return [key.replace(PER_SERVICE, s) for s in keys.SERVICES] if PER_SERVICE in key else [key]


def check_topics(doc, section: str, code_topics: dict[str, type]) -> None:
    """The rows under `section` name exactly the topics of `code_topics`, each with its message."""
    documented = {k: code(row[1]) for row in doc.get(section, []) for k in expand(code(row[0]))}
    code_keys = {k: t.__name__ for k, t in code_topics.items()}
    missing = [f"| `{k}` | [`{t}`](#{t.lower()}) | <publisher> | <rate> | <meaning> |" for k, t in code_keys.items() if k not in documented]
    assert not missing, f"{DOC}: add under '{section}':\n" + "\n".join(missing)
    extra = sorted(set(documented) - set(code_keys))
    assert not extra, f"{DOC} documents topics under '{section}' that common/keys.py lacks: {extra}"
    wrong = {k: (documented[k], t) for k, t in code_keys.items() if documented[k] != t}
    assert not wrong, f"{DOC}: '{section}' message types differ (doc, code): {wrong}"


def test_every_topic_is_documented_with_its_message(doc):
    check_topics(doc, "## Topics", keys.TOPICS)


def test_the_loop_topics_are_named_with_their_priority():
    text = DOC.read_text()
    para = text[text.index("The robot's loop goes at") :].split("\n\n", 1)[0]
    named = re.findall(r"`([a-z_/]+)`", para.split("`Priority.DATA`", 1)[1].split("On each link", 1)[0])
    assert named == sorted(keys.LOOP, key=list(keys.TOPICS).index), f"{DOC}: the loop's topics differ from keys.LOOP"


def test_every_field_topic_is_documented_with_its_message(doc):
    check_topics(doc, "## Field topics", keys.FIELD_TOPICS)


def test_every_query_is_documented_with_its_request_and_reply(doc):
    documented = {code(row[0]): (code(row[1]), code(row[2])) for row in doc.get("## Queries", [])}
    code_keys = {k: (req.__name__, rep.__name__) for k, (req, rep) in keys.QUERIES.items()}
    missing = [
        f"| `{k}` | [`{req}`](#{req.lower()}) | [`{rep}`](#{rep.lower()}) | <served by> | <meaning> |"
        for k, (req, rep) in code_keys.items()
        if k not in documented
    ]
    assert not missing, f"{DOC}: add under '## Queries':\n" + "\n".join(missing)
    extra = sorted(set(documented) - set(code_keys))
    assert not extra, f"{DOC} documents queries that common/keys.py QUERIES lacks: {extra}"
    wrong = {k: (documented[k], pair) for k, pair in code_keys.items() if documented[k] != pair}
    assert not wrong, f"{DOC}: query (request, reply) types differ (doc, code): {wrong}"


def test_every_service_has_its_liveliness_token_and_diag_topic(doc):
    rows = {code(row[0]): (code(row[1]), code(row[2])) for row in doc.get("## Services", [])}
    prefix = keys.key("r1", "")
    expected = {s: (keys.alive("r1", s).removeprefix(prefix), f"diag/{s}") for s in keys.SERVICES}
    missing = [f"| `{s}` | `{token}` | `{diag}` | <what it does> |" for s, (token, diag) in expected.items() if s not in rows]
    assert not missing, f"{DOC}: add under '## Services':\n" + "\n".join(missing)
    assert rows == expected, f"{DOC}: '## Services' rows differ from common/keys.py (doc, code): {rows} != {expected}"


def test_every_message_has_a_section(doc):
    sections = {h.removeprefix("### ") for h in doc if h.startswith("### ")}
    names = {t.__name__ for t in message_types()}
    missing = sorted(names - sections)
    assert not missing, f"{DOC}: add a '### <Name>' section with a field table under '## Messages' for: {missing}"
    extra = sorted(sections - names)
    assert not extra, f"{DOC} has sections for messages that are not on the wire: {extra}"


@pytest.mark.parametrize("typ", message_types(), ids=lambda t: t.__name__)
def test_every_field_is_documented_with_its_type_and_default(doc, typ):
    info = mi.type_info(typ)
    rows = {code(row[0]): row for row in doc.get(f"### {typ.__name__}", [])}
    missing = [field_row(f) for f in info.fields if f.encode_name not in rows]
    assert not missing, f"{DOC}: add under '### {typ.__name__}':\n" + "\n".join(missing)
    extra = sorted(set(rows) - {f.encode_name for f in info.fields})
    assert not extra, f"{DOC}: '### {typ.__name__}' documents fields that common/messages.py lacks: {extra}"
    for f in info.fields:
        row = rows[f.encode_name]
        assert len(row) == 5, f"{DOC}: '### {typ.__name__}' row `{f.encode_name}` needs 5 cells (field, type, default, unit, meaning)"
        assert (row[1], row[2]) == (type_text(f.type), default_text(f)), (
            f"{DOC}: '### {typ.__name__}' field `{f.encode_name}`: write type `{type_text(f.type)}` and default `{default_text(f)}`"
            f" (the doc says `{row[1]}` and `{row[2]}`)"
        )
        assert row[4], f"{DOC}: '### {typ.__name__}' field `{f.encode_name}` has no meaning"


@pytest.mark.parametrize(
    ("header", "values"),
    [("code", tuple(ErrorCode)), ("state", tuple(State)), ("result", tuple(GoalResult)), ("exit", tuple(Exit)), ("reason", tuple(Reason))],
)
def test_every_error_code_state_result_exit_and_reason_is_documented(header, values):
    """The tables of error codes, navigator states, goal results, move exits and refusal reasons list exactly the code's, in its order."""
    assert column(DOC.read_text(), header) == list(values), f"{DOC}: the `| {header} |` table differs from the code"


@pytest.mark.parametrize("spec", GOALS.values(), ids=lambda s: s.name)
def test_every_goal_field_is_documented_with_its_unit_and_the_slowest_speed(doc, spec):
    """A goal request's table says each field's unit as the goal schema declares it (a turn's speed in rad/s)."""
    rows = {code(row[0]): row for row in doc.get(f"### {spec.request.__name__}", [])}
    wrong = {f.name: (rows[f.name][3], f.unit) for f in spec.fields if rows[f.name][3] != f.unit}
    assert not wrong, f"{DOC}: '### {spec.request.__name__}' units differ from common/goalschema.py (doc, schema): {wrong}"
    assert f"at least {SLOWEST:g}" in rows["speed"][4], f"{DOC}: '### {spec.request.__name__}' speed: say 'at least {SLOWEST:g}'"
