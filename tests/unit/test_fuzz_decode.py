"""Fuzzing the codec: over 12,000 malformed payloads for every message of the contract.

Every failure must be a codec.BadInput naming the field or the problem, never
another exception; a value the contract forbids (wrong type, NaN, inf, out of
range, too long, missing, unknown in a request) must fail. Deterministic
(derandomized), so CI sees the same payloads on every run.
"""

from __future__ import annotations

import math
import time

import msgspec.inspect as mi
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.support.fuzz import (
    ALL_TYPES,
    FUZZ,
    REQUEST_TYPES,
    TOPIC_TYPES,
    Case,
    encode,
    ids,
    malformed,
    malformed_params,
    minimal,
    not_utf8_payloads,
    raw_map,
)
from zenav.common import codec

# 26 types x 400 payloads + 8 request types x 250 selector parameter sets: 12,400.
PAYLOADS_PER_TYPE = 400
PARAMS_PER_TYPE = 250
BATCH = 10  # payloads per Hypothesis example: the engine's cost is per example
DEEP = 100_000  # nesting levels of the deep payloads
FAST = 0.1  # [s] a huge declared length must be refused without reading that much


# ------------------------------------------------------------ checks
def check(typ: type, case: Case) -> None:
    """Decoding `case` gives a valid message or a BadInput naming the problem; nothing else."""
    try:
        msg = codec.decode(case.payload, typ)
    except codec.BadInput as e:
        text = str(e)
        assert text.startswith(f"{typ.__name__}: ") and len(text) > len(typ.__name__) + 2, text
        if case.names is not None:
            assert case.names in text, f"{case.kind}: {text!r} does not name {case.names!r}"
        return
    assert isinstance(msg, typ)
    assert not case.must_fail, f"{case.kind}: accepted {msg!r}"


def check_params(typ: type, params: dict[str, str], names: str | None) -> None:
    """Selector parameters give a valid request or a BadInput naming the problem."""
    try:
        req = codec.from_params(params, typ)
    except codec.BadInput as e:
        assert str(e).startswith(f"{typ.__name__}: "), str(e)
        if names is not None:
            assert names in str(e), f"{e} does not name {names}"
        return
    assert isinstance(req, typ) and names is None, f"{params} accepted as {req!r}"


@pytest.mark.parametrize("typ", ALL_TYPES, ids=ids(ALL_TYPES))
def test_malformed_payloads_are_bad_input(typ):
    checked = []

    @settings(FUZZ, max_examples=PAYLOADS_PER_TYPE // BATCH)
    @given(st.lists(malformed(typ), min_size=BATCH, max_size=BATCH))
    def run(cases: list[Case]) -> None:
        for case in cases:
            check(typ, case)
        checked.extend(cases)

    run()
    assert len(checked) >= PAYLOADS_PER_TYPE


@pytest.mark.parametrize("typ", REQUEST_TYPES, ids=ids(REQUEST_TYPES))
def test_malformed_selector_params_are_bad_input(typ):
    checked = []

    @settings(FUZZ, max_examples=PARAMS_PER_TYPE // BATCH)
    @given(st.lists(malformed_params(typ), min_size=BATCH, max_size=BATCH))
    def run(cases: list[tuple[dict[str, str], str | None]]) -> None:
        for params, names in cases:
            check_params(typ, params, names)
        checked.extend(cases)

    run()
    assert len(checked) >= PARAMS_PER_TYPE


def float_sites(t: mi.Type) -> list:
    """Builders of a value of type `t` holding a given float at one of its float places."""
    if isinstance(t, mi.FloatType):
        return [lambda x: x]
    if isinstance(t, mi.UnionType):
        return [s for u in t.types for s in float_sites(u)]
    if isinstance(t, (mi.ListType, mi.VarTupleType)):
        rest = [minimal(t.item_type)] * max(0, (t.min_length or 1) - 1)
        return [lambda x, s=s: [s(x), *rest] for s in float_sites(t.item_type)]
    if isinstance(t, mi.DictType):
        return [lambda x, s=s: {"k": s(x)} for s in float_sites(t.value_type)]
    return []


NAN_TYPES = TOPIC_TYPES + REQUEST_TYPES


@pytest.mark.parametrize("typ", NAN_TYPES, ids=ids(NAN_TYPES))
@pytest.mark.parametrize("x", [math.nan, math.inf, -math.inf], ids=["nan", "inf", "-inf"])
def test_nan_and_inf_are_bad_input_in_every_float_field(typ, x):
    info = mi.type_info(typ)
    base = minimal(info)
    for f in info.fields:
        for site in float_sites(f.type):
            with pytest.raises(codec.BadInput, match=rf"\$\.{f.encode_name}"):
                codec.decode(encode({**base, f.encode_name: site(x)}), typ)


DEEP_VALUES = {
    "arrays": b"\x91" * DEEP + b"\xc0",  # [[[...nil...]]]
    "maps": (b"\x81" + encode("k")) * DEEP + b"\xc0",  # {k: {k: ...nil...}}
    "map of arrays": b"\x81" + encode("k") + b"\x91" * DEEP + b"\xc0",  # reaches map values
}


@pytest.mark.parametrize("typ", ALL_TYPES, ids=ids(ALL_TYPES))
def test_deep_nesting_is_bad_input(typ):
    """Even where msgspec walks a value however deep (an ignored key, an Any field)."""
    info = mi.type_info(typ)
    base = {k: encode(v) for k, v in minimal(info).items()}
    for deep in DEEP_VALUES.values():
        with pytest.raises(codec.BadInput):
            codec.decode(deep, typ)
        for name in [f.encode_name for f in info.fields] + ["not_a_field"]:
            with pytest.raises(codec.BadInput):
                codec.decode(raw_map(list({**base, name: deep}.items())), typ)


@pytest.mark.parametrize("typ", REQUEST_TYPES, ids=ids(REQUEST_TYPES))
def test_deeply_nested_selector_params_are_bad_input(typ):
    for name in [f.encode_name for f in mi.type_info(typ).fields] or ["x"]:
        with pytest.raises(codec.BadInput):
            codec.from_params({name: "[" * DEEP}, typ)


HUGE_HEADERS = {
    "array32 of 2^32-1 items": b"\xdd\xff\xff\xff\xff",
    "map32 of 2^32-1 pairs": b"\xdf\xff\xff\xff\xff",
    "str32 of 4 GiB": b"\xdb\xff\xff\xff\xff",
    "bin32 of 4 GiB": b"\xc6\xff\xff\xff\xff",
}


@pytest.mark.parametrize("typ", ALL_TYPES, ids=ids(ALL_TYPES))
def test_huge_declared_lengths_fail_fast(typ):
    info = mi.type_info(typ)
    base = {k: encode(v) for k, v in minimal(info).items()}
    for head in HUGE_HEADERS.values():
        payloads = [head, *(raw_map(list({**base, f.encode_name: head}.items())) for f in info.fields)]
        for payload in payloads:
            t0 = time.perf_counter()
            with pytest.raises(codec.BadInput):
                codec.decode(payload, typ)
            assert time.perf_counter() - t0 < FAST


@pytest.mark.parametrize("typ", ALL_TYPES, ids=ids(ALL_TYPES))
def test_text_that_is_not_utf8_is_bad_input(typ):
    """In a str field, a map key, an Any value, or an unknown key (ignored by topics and replies)."""
    *in_fields, unknown_key = not_utf8_payloads(typ)
    for payload in in_fields:
        with pytest.raises(codec.BadInput):
            codec.decode(payload, typ)
    if mi.type_info(typ).forbid_unknown_fields:
        with pytest.raises(codec.BadInput):
            codec.decode(unknown_key, typ)
    else:
        assert isinstance(codec.decode(unknown_key, typ), typ)
