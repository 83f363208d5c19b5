"""The one codec: msgpack via msgspec. Services never touch bytes."""

from __future__ import annotations

import json
from collections.abc import Mapping
from typing import Any, TypeVar

import msgspec

T = TypeVar("T")

_encoder = msgspec.msgpack.Encoder()
_decoders: dict[type, msgspec.msgpack.Decoder] = {}


class BadInput(ValueError):
    """A payload that is not a valid message of the expected type."""


def encode(msg: Any) -> bytes:
    """Encode a message (or any msgpack-able value) to bytes."""
    return _encoder.encode(msg)


def decode(data: bytes, typ: type[T]) -> T:
    """Decode and validate bytes as `typ`; raise BadInput naming the problem."""
    dec = _decoders.get(typ)
    if dec is None:
        dec = _decoders[typ] = msgspec.msgpack.Decoder(typ)
    try:
        return dec.decode(data)
    except (msgspec.ValidationError, msgspec.DecodeError) as e:
        raise BadInput(f"{typ.__name__}: {e}") from None
    except UnicodeDecodeError:
        raise BadInput(f"{typ.__name__}: a string is not valid UTF-8") from None
    except RecursionError:  # e.g. a thousand nested arrays under an ignored key
        raise BadInput(f"{typ.__name__}: payload nested too deeply") from None


def _param_value(text: str) -> Any:
    # Selector parameters are text; JSON-looking values (lists, maps) are parsed so
    # that `points=[[0,0],[1,0]]` works from generic Zenoh tools.
    if text[:1] in "[{":
        try:
            return json.loads(text)
        except (ValueError, RecursionError):
            return text  # left as text: validation then names the field
    return text


def from_params(params: Mapping[str, str], typ: type[T]) -> T:
    """Build a request from selector parameters (`?x=1;y=0.5`), converting text."""
    try:
        return msgspec.convert({k: _param_value(v) for k, v in params.items()}, typ, strict=False)
    except msgspec.ValidationError as e:
        raise BadInput(f"{typ.__name__}: {e}") from None
    except RecursionError:
        raise BadInput(f"{typ.__name__}: parameters nested too deeply") from None
