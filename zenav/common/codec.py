"""The one codec: msgpack via msgspec. Services never touch bytes."""

from __future__ import annotations

import difflib
import json
import math
import re
from collections.abc import Mapping
from typing import Any, TypeVar, cast

import msgspec

T = TypeVar("T")

_encoder = msgspec.msgpack.Encoder()
_decoders: dict[type, msgspec.msgpack.Decoder[Any]] = {}


class BadInput(ValueError):
    """A payload that is not a valid message of the expected type."""


def invalid(typ: type, error: Exception, value: Any = None) -> str:
    """What is wrong with `value` as a `typ`: msgspec's error, and the value where it is a nan or infinity,
    or the field an unknown one was a typo of."""
    try:
        found = _nonfinite(value)
    except RecursionError:
        found = None
    note = f" (`{found[0]}` is {found[1]}: a number must be finite)" if found and f"at `{found[0]}`" in str(error) else ""
    return f"{typ.__name__}: {error}{note}{nearest_field(typ, str(error))}"


def nearest_field(typ: type, error: str) -> str:
    """` (did you mean `tolerance`?)` when msgspec's error is an unknown field of `typ` itself that is a typo of one of its own."""
    unknown = re.fullmatch(r"Object contains unknown field `([^`]*)`", error)
    if unknown is None or not (isinstance(typ, type) and issubclass(typ, msgspec.Struct)):
        return ""
    near = difflib.get_close_matches(unknown.group(1), [f.encode_name for f in msgspec.structs.fields(typ)], n=1)
    return f" (did you mean `{near[0]}`?)" if near else ""


def _nonfinite(value: Any, path: str = "$") -> tuple[str, float] | None:
    """The path and value of the first float in a decoded value that is nan or infinite; None if there is none."""
    if isinstance(value, float):
        return None if math.isfinite(value) else (path, value)
    if isinstance(value, dict):
        items: Any = ((f"{path}.{k}", v) for k, v in value.items())
    elif isinstance(value, list | tuple):
        items = ((f"{path}[{i}]", v) for i, v in enumerate(value))
    else:
        return None
    return next((found for p, v in items if (found := _nonfinite(v, p)) is not None), None)


def encode(msg: Any) -> bytes:
    """Encode a message (or any msgpack-able value) to bytes."""
    return _encoder.encode(msg)


def decode(data: bytes, typ: type[T]) -> T:
    """Decode and validate bytes as `typ`; raise BadInput naming the problem."""
    dec = _decoders.get(typ)
    if dec is None:
        dec = _decoders[typ] = msgspec.msgpack.Decoder(typ)
    try:
        return cast(T, dec.decode(data))
    except msgspec.ValidationError as e:
        raise BadInput(invalid(typ, e, _untyped(data))) from None
    except msgspec.DecodeError as e:
        raise BadInput(f"{typ.__name__}: {e}") from None
    except UnicodeDecodeError:
        raise BadInput(f"{typ.__name__}: a string is not valid UTF-8") from None
    except RecursionError:  # e.g. a thousand nested arrays under an ignored key
        raise BadInput(f"{typ.__name__}: payload nested too deeply") from None


def _untyped(data: bytes) -> Any:
    """The payload decoded without a type, to name what a validation error was about; None if that fails too."""
    try:
        return msgspec.msgpack.decode(data)
    except (msgspec.DecodeError, UnicodeDecodeError, RecursionError):
        return None


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
    values = {k: _param_value(v) for k, v in params.items()}
    try:
        return msgspec.convert(values, typ, strict=False)
    except msgspec.ValidationError as e:
        raise BadInput(invalid(typ, e, values)) from None
    except RecursionError:
        raise BadInput(f"{typ.__name__}: parameters nested too deeply") from None
