"""The fuzz strategies themselves: a `valid` value really is valid (so a payload with one
bad field differs from a valid message in that field only), and the minimal value too."""

from __future__ import annotations

import msgspec.inspect as mi
import pytest
from hypothesis import given, settings

from tests.support.fuzz import ALL_TYPES, FUZZ, encode, ids, minimal, valid
from zenav.common import codec


@pytest.mark.parametrize("typ", ALL_TYPES, ids=ids(ALL_TYPES))
def test_the_valid_strategy_makes_valid_messages(typ):
    """So that a `one bad field` payload differs from a valid one in that field only."""

    @settings(FUZZ, max_examples=50)
    @given(valid(mi.type_info(typ)))
    def run(value: dict) -> None:
        assert isinstance(codec.decode(encode(value), typ), typ)

    run()


@pytest.mark.parametrize("typ", ALL_TYPES, ids=ids(ALL_TYPES))
def test_the_minimal_value_is_valid(typ):
    assert isinstance(codec.decode(encode(minimal(mi.type_info(typ))), typ), typ)
