"""Malformed payloads for every message of the contract, as Hypothesis strategies.

Built from each message's msgspec type info, so a new field is fuzzed without
edits here. tests/unit/test_fuzz_decode.py feeds them to the codec and
tests/system/test_fuzz.py to running services; tests/unit/test_fuzz_payloads.py
checks the strategies themselves.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import msgspec
import msgspec.inspect as mi
from hypothesis import HealthCheck, Phase, settings
from hypothesis import strategies as st

from zenav.common import keys
from zenav.common.runtime import FORMAT_PARAM

TOPIC_TYPES = list(dict.fromkeys(keys.TOPICS.values()))
REQUEST_TYPES = list(dict.fromkeys(req for req, _ in keys.QUERIES.values()))
REPLY_TYPES = list(dict.fromkeys(rep for _, rep in keys.QUERIES.values()))
ALL_TYPES = TOPIC_TYPES + REQUEST_TYPES + REPLY_TYPES
FUZZ = settings(
    derandomize=True,  # the same examples on every run: CI is reproducible
    database=None,
    deadline=None,
    phases=[Phase.explicit, Phase.generate, Phase.shrink],
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)


@dataclass(frozen=True)
class Case:
    """A payload, and what decoding it must do."""

    payload: bytes
    must_fail: bool  # False: BadInput or a valid message (random data may be valid)
    names: str | None = None  # text the BadInput message must contain
    kind: str = ""  # which strategy made it (shown on failure)


# ------------------------------------------------------------ value strategies
KINDS = {
    "nil": st.none(),
    "bool": st.booleans(),
    "int": st.integers(-(2**63), 2**64 - 1),
    "float": st.floats(),
    "str": st.text(max_size=8),
    "bin": st.binary(max_size=8),
    "array": st.lists(st.integers(0, 9), max_size=3),
    "map": st.dictionaries(st.text(max_size=3), st.integers(0, 9), max_size=2),
}


def accepted_kinds(t: mi.Type) -> set[str]:
    """The msgpack kinds a field of type `t` can decode from."""
    if isinstance(t, mi.AnyType):
        return set(KINDS)
    if isinstance(t, mi.UnionType):
        return set().union(*(accepted_kinds(u) for u in t.types))
    if isinstance(t, mi.LiteralType):
        return {"str" if isinstance(v, str) else "int" for v in t.values}
    return {
        mi.FloatType: {"int", "float"},
        mi.IntType: {"int"},
        mi.StrType: {"str"},
        mi.BoolType: {"bool"},
        mi.NoneType: {"nil"},
        mi.BytesType: {"bin"},
        mi.ListType: {"array"},
        mi.VarTupleType: {"array"},
        mi.TupleType: {"array"},
        mi.DictType: {"map"},
        mi.StructType: {"map"},
    }[type(t)]


def bounds(t: mi.FloatType | mi.IntType) -> tuple[float | None, float | None]:
    """(lowest, highest) a number type allows, None where unbounded."""
    lo = t.ge if t.ge is not None else t.gt
    hi = t.le if t.le is not None else t.lt
    return lo, hi


def valid(t: mi.Type) -> st.SearchStrategy:
    """Values a field of type `t` accepts."""
    if isinstance(t, mi.FloatType):
        lo, hi = bounds(t)
        return st.floats(
            min_value=-1e9 if lo is None else lo,
            max_value=1e9 if hi is None else hi,
            exclude_min=t.gt is not None,
            exclude_max=t.lt is not None,
            allow_nan=False,
            allow_infinity=False,
        )
    if isinstance(t, mi.IntType):
        lo, hi = bounds(t)
        return st.integers(-(2**63) if lo is None else int(lo), 2**63 - 1 if hi is None else int(hi))
    if isinstance(t, mi.StrType):
        if t.pattern:
            return st.from_regex(t.pattern, fullmatch=True)
        lo = t.min_length or 0
        return st.text(min_size=lo, max_size=max(lo, min(t.max_length or 8, 8)))
    if isinstance(t, mi.BoolType):
        return st.booleans()
    if isinstance(t, mi.LiteralType):
        return st.sampled_from(t.values)
    if isinstance(t, mi.NoneType):
        return st.none()
    if isinstance(t, mi.BytesType):
        return st.binary(max_size=8)
    if isinstance(t, mi.AnyType):
        return st.none() | st.integers(-9, 9) | st.text(max_size=4)
    if isinstance(t, mi.UnionType):
        return st.one_of([valid(u) for u in t.types])
    if isinstance(t, (mi.ListType, mi.VarTupleType)):
        lo = t.min_length or 0
        return st.lists(valid(t.item_type), min_size=lo, max_size=max(lo, min(t.max_length or 4, 4)))
    if isinstance(t, mi.TupleType):
        return st.tuples(*map(valid, t.item_types)).map(list)
    if isinstance(t, mi.DictType):
        return st.dictionaries(valid(t.key_type), valid(t.value_type), max_size=3)
    if isinstance(t, mi.StructType):
        return st.fixed_dictionaries(
            {f.encode_name: valid(f.type) for f in t.fields if f.required},
            optional={f.encode_name: valid(f.type) for f in t.fields if not f.required},
        )
    raise TypeError(f"no strategy for {t}")


def out_of_range(t: mi.Type) -> list[st.SearchStrategy]:
    """Values of an accepted kind that the contract forbids for type `t`."""
    out: list[st.SearchStrategy] = []
    if isinstance(t, mi.FloatType):
        lo, hi = bounds(t)
        if hi is not None:
            out += [st.floats(min_value=hi, exclude_min=t.le is not None, allow_nan=False), st.integers(math.floor(hi) + 1, 2**64 - 1)]
        if lo is not None:
            out += [st.floats(max_value=lo, exclude_max=t.ge is not None, allow_nan=False), st.integers(-(2**63), math.ceil(lo) - 1)]
        if lo is not None or hi is not None:
            out.append(st.just(math.nan))  # an unbounded float field lets NaN in: see test_nan_and_inf
    elif isinstance(t, mi.IntType):
        lo, hi = bounds(t)
        if hi is not None and hi < 2**64 - 1:
            out.append(st.integers(int(hi) + 1, 2**64 - 1))
        if lo is not None and lo > -(2**63):
            out.append(st.integers(-(2**63), int(lo) - 1))
    elif isinstance(t, mi.LiteralType):
        out.append(st.text(max_size=8).filter(lambda v, values=t.values: v not in values))
    elif isinstance(t, mi.StrType):
        if t.max_length is not None:
            out.append(st.text(min_size=t.max_length + 1, max_size=t.max_length + 8))
        if t.min_length:
            out.append(st.text(max_size=t.min_length - 1))
    elif isinstance(t, mi.UnionType):
        members = [u for u in t.types if not isinstance(u, mi.NoneType)]
        if len(members) == 1:  # Optional[X]
            out += [s.filter(lambda v: v is not None) for s in out_of_range(members[0])]
    elif isinstance(t, (mi.ListType, mi.VarTupleType)):
        item = valid(t.item_type)
        if t.max_length is not None:  # huge arrays: a path of max + 1 points
            out.append(item.map(lambda v, n=t.max_length + 1: [v] * n))
        if t.min_length:
            out.append(st.lists(item, max_size=t.min_length - 1))
        bad_item = bad(t.item_type)
        if bad_item is not None:
            out.append(
                st.builds(
                    lambda xs, i, v: xs[: i % len(xs)] + [v] + xs[i % len(xs) + 1 :],
                    st.lists(item, min_size=max(1, t.min_length or 0), max_size=max(1, t.min_length or 0, min(t.max_length or 4, 4))),
                    st.integers(0, 3),
                    bad_item,
                )
            )
    elif isinstance(t, mi.DictType):
        bad_key, bad_value = bad(t.key_type), bad(t.value_type)
        if bad_key is not None:  # keys of a scalar kind the key type refuses (maps and arrays are not hashable)
            keys_ = st.one_of([s for kind, s in KINDS.items() if kind in {"nil", "bool", "int", "bin", "str"} - accepted_kinds(t.key_type)])
            out.append(st.dictionaries(keys_, valid(t.value_type), min_size=1, max_size=2))
        if bad_value is not None:
            out.append(st.dictionaries(valid(t.key_type), bad_value, min_size=1, max_size=2))
    elif isinstance(t, mi.StructType) and any(f.required for f in t.fields):
        out.append(
            st.builds(
                lambda d, f: {k: v for k, v in d.items() if k != f},
                valid(t),
                st.sampled_from([f.encode_name for f in t.fields if f.required]),
            )
        )
    return out


def bad(t: mi.Type) -> st.SearchStrategy | None:
    """Values the contract forbids for type `t` (wrong kind or out of range); None if none."""
    wrong = [s for kind, s in KINDS.items() if kind not in accepted_kinds(t)]
    options = wrong + out_of_range(t)
    return st.one_of(options) if options else None


# ------------------------------------------------------------ payload strategies
def msgpack_values(max_leaves: int = 10) -> st.SearchStrategy:
    """Any msgpack value: scalars of every kind, nested arrays and maps with any keys."""
    scalars = st.one_of(list(KINDS.values())[:6])
    return st.recursive(
        scalars,
        lambda inner: (
            st.lists(inner, max_size=4)
            | st.dictionaries(scalars.filter(lambda k: not isinstance(k, float) or not math.isnan(k)), inner, max_size=4)
        ),
        max_leaves=max_leaves,
    )


def encode(value: object) -> bytes:
    """Any value as msgpack (NaN, 64-bit ints and non-string keys included)."""
    return msgspec.msgpack.encode(value)


def malformed(typ: type) -> st.SearchStrategy[Case]:
    """Malformed payloads for message type `typ`, each with what decoding must do."""
    info = mi.type_info(typ)
    request = info.forbid_unknown_fields
    names = [f.encode_name for f in info.fields]
    required = [f.encode_name for f in info.fields if f.required]
    fields_with_bad = [(f.encode_name, bad(f.type)) for f in info.fields]
    fields_with_bad = [(n, s) for n, s in fields_with_bad if s is not None]
    options = [
        st.binary(max_size=64).map(lambda b: Case(b, False, kind="random bytes")),
        msgpack_values().map(lambda v: Case(encode(v), False, kind="any msgpack value")),
        st.builds(lambda v, cut: Case(encode(v)[:cut], False, kind="truncated"), valid(info), st.integers(0, 64)),
        st.builds(lambda v: Case(encode(v) + b"\xc0", True, "trailing", kind="trailing bytes"), valid(info)),
    ]
    options += [
        st.builds(lambda v, x, n=name: Case(encode({**v, n: x}), True, f"$.{n}", kind="one bad field"), valid(info), b)
        for name, b in fields_with_bad
    ]
    if required:
        options.append(
            st.builds(
                lambda v, n: Case(encode({k: x for k, x in v.items() if k != n}), True, f"`{n}`", kind="missing field"),
                valid(info),
                st.sampled_from(required),
            )
        )
    unknown = st.text(min_size=1, max_size=12).filter(lambda k: k not in names)
    options.append(
        st.builds(
            lambda v, k, x: Case(encode({**v, k: x}), request, f"`{k}`" if request else None, kind="unknown field"),
            valid(info),
            unknown,
            msgpack_values(5),
        )
    )
    return st.one_of(options)


def as_params(value: dict) -> dict[str, str]:
    """A request as selector parameters, written as a generic Zenoh tool would."""
    text = {bool: lambda b: str(b).lower(), list: lambda v: msgspec.json.encode(v).decode()}
    return {k: text.get(type(x), str)(x) for k, x in value.items() if x is not None}


def params_of(info: mi.StructType) -> st.SearchStrategy[dict[str, str]]:
    """Valid requests as selector parameters (text that looks like JSON is parsed as JSON)."""
    return valid(info).map(as_params).filter(lambda p: not any(v[:1] in ("[", "{") for k, v in p.items() if k == "lease"))


def malformed_params(typ: type) -> st.SearchStrategy[tuple[dict[str, str], str | None]]:
    """Selector parameters for request `typ`, with what the error must name (None: may be valid)."""
    info = mi.type_info(typ)
    names = {f.encode_name for f in info.fields}
    text_of_bad = st.one_of(
        st.sampled_from(["nan", "inf", "-inf", "1e999", "", "abc", "[1,2", "[[1]]", "{}", "None", "0x10", "1,5"]),
        st.text(max_size=12),
    )
    options = [
        st.dictionaries(st.text(max_size=8), st.text(max_size=12), max_size=4).map(lambda p: (p, None)),
        st.builds(
            lambda p, k: ({**p, k: "1"}, f"`{k}`"),
            params_of(info),
            # names beginning with `_` are Zenoh's, ignored by the contract: not unknown fields
            st.text(min_size=1, max_size=8).filter(lambda k: k not in names and not k.startswith("_")),
        ),
    ]
    options += [st.builds(lambda p, x, n=name: ({**p, n: x}, None), params_of(info), text_of_bad) for name in sorted(names)]
    # With zenav's own `_format`, the reply's encoding: one it does not know is refused, a known one encodes the error.
    formats = st.one_of(st.sampled_from(["json", "msgpack", "", "JSON", "yaml"]), st.text(max_size=12))
    options.append(st.builds(lambda case, f: ({**case[0], FORMAT_PARAM: f}, None), st.one_of(options), formats))
    return st.one_of(options)


def minimal(t: mi.Type) -> object:
    """The simplest valid value of type `t`."""
    if isinstance(t, (mi.FloatType, mi.IntType)):
        lo, hi = bounds(t)
        cast = float if isinstance(t, mi.FloatType) else int
        for v in (0, 1, -1, lo, hi):
            if (
                v is not None
                and (lo is None or v > lo or (v == lo and t.gt is None))
                and (hi is None or v < hi or (v == hi and t.lt is None))
            ):
                return cast(v)
    if isinstance(t, mi.StrType):
        return "a" * (t.min_length or 0)
    if isinstance(t, mi.BoolType):
        return False
    if isinstance(t, mi.LiteralType):
        return t.values[0]
    if isinstance(t, (mi.NoneType, mi.AnyType)):
        return None
    if isinstance(t, mi.UnionType):
        return minimal(t.types[0])
    if isinstance(t, (mi.ListType, mi.VarTupleType)):
        return [minimal(t.item_type)] * (t.min_length or 0)
    if isinstance(t, mi.TupleType):
        return [minimal(u) for u in t.item_types]
    if isinstance(t, mi.DictType):
        return {}
    if isinstance(t, mi.BytesType):
        return b"\x00" * (t.min_length or 0)
    if isinstance(t, mi.StructType):
        return {f.encode_name: minimal(f.type) for f in t.fields if f.required}
    raise TypeError(f"no minimal value for {t}")


def raw_map(items: list[tuple[str, bytes]]) -> bytes:
    """A msgpack map of already encoded values."""
    head = bytes([0x80 | len(items)]) if len(items) < 16 else b"\xde" + len(items).to_bytes(2, "big")
    return head + b"".join(encode(k) + v for k, v in items)


NOT_UTF8 = b"\xa3\xff\xfe\xfd"  # a msgpack str of three bytes that are not UTF-8
_MARK = "\ue000"  # stands for it while encoding: its msgpack form has the same length
_MARK_BYTES = msgspec.msgpack.encode(_MARK)


def text_sites(t: mi.Type) -> list:
    """Builders of a value of type `t` with the mark at one of its text places (str, map key, Any)."""
    if isinstance(t, (mi.StrType, mi.AnyType)):
        return [lambda: _MARK]
    if isinstance(t, mi.UnionType):
        return [s for u in t.types for s in text_sites(u)]
    if isinstance(t, (mi.ListType, mi.VarTupleType)):
        rest = [minimal(t.item_type)] * max(0, (t.min_length or 1) - 1)
        return [lambda s=s: [s(), *rest] for s in text_sites(t.item_type)]
    if isinstance(t, mi.DictType):
        keys_ = [lambda s=s: {s(): minimal(t.value_type)} for s in text_sites(t.key_type)]
        return keys_ + [lambda s=s: {"k": s()} for s in text_sites(t.value_type)]
    return []


def not_utf8(value: object) -> bytes:
    """`value` encoded, its mark replaced by text that is not UTF-8."""
    data = encode(value)
    assert data.count(_MARK_BYTES) == 1
    return data.replace(_MARK_BYTES, NOT_UTF8)


def not_utf8_payloads(typ: type) -> list[bytes]:
    """A message of `typ` with text that is not UTF-8 at each text place, and as an unknown key."""
    info = mi.type_info(typ)
    base = minimal(info)
    out = [not_utf8({**base, f.encode_name: site()}) for f in info.fields for site in text_sites(f.type)]
    return out + [not_utf8({**base, _MARK: 1})]


def ids(types: list[type]) -> list[str]:
    """Test ids: the message names."""
    return [t.__name__ for t in types]
