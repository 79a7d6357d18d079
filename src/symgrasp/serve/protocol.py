"""The grasp server's wire format, shared by the server and the client: HTTP + JSON, arrays as
nested lists or as base64 of their little-endian bytes (docs/serve.md is the reference).

This module needs only the standard library and numpy, so that the client
(`symgrasp.serve.client`) runs in a robot's process without torch. The paths, the port and the
version are `symgrasp.serve`'s names.
"""

from __future__ import annotations

import base64
import binascii
import itertools
import json
import math
import reprlib
from pathlib import Path
from typing import Any

import numpy as np

from symgrasp.serve import DEFAULT_PORT, DETECT_PATH, HEALTH_PATH, PROTOCOL

MAX_BODY = 256 * 2**20
"""[bytes] the largest request accepted (eight 1280 × 720 float32 depth images in base64 take
about 40 MB)."""

MAX_VALUES = 2**23
"""The most JSON values (numbers, strings, lists, …) a request may hold: eight 1280 × 720 depth
images as nested lists, about 0.4 GiB once parsed and decoded. Counted on the bytes, before they
are parsed: a nested list of numbers costs about 7 times its text."""

MAX_DIMS = 8
"""The most dimensions an array may have (the protocol's have at most 3); a deeper one is refused
before it is built."""

DTYPES = {"float32": "<f4", "float64": "<f8", "uint16": "<u2"}
"""The element types an encoded array may have (little-endian, whatever the machine)."""

SCHEMA = Path(__file__).with_name("schema.json")
"""The JSON Schema (draft 2020-12) of the request, the answer, the health answer and the errors,
shipped with the package: its ``$defs`` ``request``, ``answer``, ``health``, ``error``."""


__all__ = [
    "DEFAULT_PORT", "DETECT_PATH", "DTYPES", "HEALTH_PATH", "MAX_BODY", "MAX_DIMS", "MAX_VALUES",
    "PROTOCOL", "SCHEMA", "RequestError", "decode_array", "encode_array", "parse_request",
]  # fmt: skip


class RequestError(ValueError):
    """A request the server refuses (HTTP 400); the message names the field and what was
    expected."""


def parse_request(data: bytes | bytearray) -> Any:
    """A request's body ``data`` parsed as JSON, refused (`RequestError`) before it is parsed
    when it holds more than `MAX_VALUES` values, and when it is not strict JSON (NaN and
    Infinity are not: null is a missing value) or nests deeper than Python's recursion limit."""
    # every value is the body itself, the first of a list or an object's value ("[", ":"), or
    # follows a "," (as does each key but an object's first, which follows a "{"): exact but
    # for one more per empty list or object, and these characters inside strings
    values = 1 + sum(data.count(mark) for mark in (b"[", b"{", b",", b":"))
    if values > MAX_VALUES:
        raise RequestError(
            f"the request holds up to {values} JSON values, over the {MAX_VALUES} accepted "
            "(send large arrays in base64)"
        )
    try:
        return json.loads(data, parse_constant=_refuse_constant)
    except RequestError:
        raise
    except RecursionError:
        raise RequestError("the request nests its JSON too deep") from None
    except ValueError as error:  # JSONDecodeError, bytes that are not UTF-8, huge integers
        raise RequestError(f"the request is not JSON: {error}") from None


def _refuse_constant(name: str) -> None:
    raise RequestError(f"the request is not JSON: {name} is no JSON number (null: a missing value)")


def is_number(value: Any) -> bool:
    """Whether the parsed JSON ``value`` is a number (true and false are not, although Python's
    bool is an int)."""
    return isinstance(value, int | float) and not isinstance(value, bool)


def shown(value: Any) -> str:
    """``value`` as an error message shows it: its repr, shortened (a request's values can be
    any size)."""
    return reprlib.repr(value)


def encode_array(array: np.ndarray) -> dict[str, Any]:
    """``array`` as ``{"dtype", "shape", "data"}``: its little-endian bytes in C order, base64
    (RFC 4648). Floating-point arrays other than float32/float64 travel as float64."""
    array = np.asarray(array)
    if array.dtype.name not in DTYPES:
        if not (np.issubdtype(array.dtype, np.floating) or np.issubdtype(array.dtype, np.integer)):
            raise ValueError(f"cannot encode an array of {array.dtype}: expected numbers")
        array = array.astype(np.float64)
    name = array.dtype.name
    data = np.ascontiguousarray(array, dtype=DTYPES[name]).tobytes()
    return {"dtype": name, "shape": list(array.shape), "data": base64.b64encode(data).decode()}


def decode_array(
    value: Any, field: str, dtypes: tuple[str, ...] = ("float32", "float64")
) -> np.ndarray:
    """The array of a request's ``field``: nested lists of numbers (read as float64, null as
    NaN), or the encoded form of `encode_array` with a dtype among ``dtypes``. `RequestError`
    naming the field for anything else: strings and booleans where numbers are due, ragged
    lists, more than `MAX_DIMS` dimensions, data off its shape; both forms are checked whole
    before an array is built."""
    if isinstance(value, dict):
        return _decode_encoded(value, field, dtypes)
    if not isinstance(value, list):
        raise RequestError(
            f"{field} must be an array: nested lists of numbers or "
            f'{{"dtype", "shape", "data"}}, got {type(value).__name__}'
        )
    shape, level = [], [value]
    while level and isinstance(level[0], list):
        sizes = set(map(len, level)) if set(map(type, level)) == {list} else set()
        if len(sizes) != 1:
            raise RequestError(
                f"{field} must be nested lists of numbers of one rectangular shape; its lists "
                f"at depth {len(shape) + 1} differ in length or mix lists and numbers"
            )
        shape.append(sizes.pop())
        if len(shape) > MAX_DIMS:
            raise RequestError(f"{field} must have at most {MAX_DIMS} dimensions")
        level = list(itertools.chain.from_iterable(level))
    kinds = set(map(type, level)) - {int, float, type(None)}
    if kinds:
        names = ", ".join(sorted(_JSON_KINDS.get(kind, kind.__name__) for kind in kinds))
        raise RequestError(
            f"{field} must be nested lists of numbers of one rectangular shape (null: missing), "
            f"got {names} among them"
        )
    try:
        return np.array(level, dtype=np.float64).reshape(shape)
    except OverflowError:  # an integer beyond float64
        raise RequestError(f"{field} holds a number beyond float64's range") from None


_JSON_KINDS = {bool: "true/false", str: "strings", dict: "objects", list: "lists"}
"""What JSON calls the Python types a parsed request holds, for error messages."""


def _decode_encoded(value: dict[str, Any], field: str, dtypes: tuple[str, ...]) -> np.ndarray:
    missing = [key for key in ("dtype", "shape", "data") if key not in value]
    if missing:
        raise RequestError(
            f"{field} lacks {', '.join(missing)} (an encoded array has dtype, shape, data)"
        )
    name, shape, data = value["dtype"], value["shape"], value["data"]
    if name not in dtypes:
        raise RequestError(f"{field}.dtype must be one of {', '.join(dtypes)}, got {shown(name)}")
    if not (
        isinstance(shape, list)
        and len(shape) <= MAX_DIMS
        and all(isinstance(n, int) and not isinstance(n, bool) and n >= 0 for n in shape)
    ):
        raise RequestError(
            f"{field}.shape must be a list of sizes ≥ 0, at most {MAX_DIMS}, got {shown(shape)}"
        )
    if not isinstance(data, str):
        raise RequestError(f"{field}.data must be a base64 string, got {type(data).__name__}")
    if len(data) % 4:
        raise RequestError(
            f"{field}.data is not base64 (its length {len(data)} is not a multiple of 4)"
        )
    # the decoded size read off the text's length: checked before anything is decoded
    size = len(data) // 4 * 3 - (len(data) - len(data.rstrip("=")))
    expected = math.prod(shape) * np.dtype(DTYPES[name]).itemsize
    if size != expected:
        raise RequestError(
            f"{field}.data holds {size} bytes; shape {shape} of {name} needs {expected}"
        )
    try:
        raw = base64.b64decode(data, validate=True)
    except (binascii.Error, ValueError) as error:
        raise RequestError(f"{field}.data is not base64 ({error})") from None
    return np.frombuffer(raw, dtype=DTYPES[name]).reshape(shape).astype(name)


def optional_number(body: dict[str, Any], field: str, low: float, high: float) -> float | None:
    """``body[field]`` as a float in [low, high], or None when absent or null."""
    value = body.get(field)
    if value is None:
        return None
    if not is_number(value) or not low <= value <= high:
        raise RequestError(f"{field} must be a number in [{low:g}, {high:g}], got {shown(value)}")
    return float(value)


def optional_integer(body: dict[str, Any], field: str, low: int, high: int) -> int | None:
    """``body[field]`` as an int in [low, high], or None when absent or null."""
    value = body.get(field)
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise RequestError(f"{field} must be an integer in [{low}, {high}], got {shown(value)}")
    return value


def optional_flag(body: dict[str, Any], field: str) -> bool:
    """``body[field]`` as a bool (absent: False)."""
    value = body.get(field, False)
    if not isinstance(value, bool):
        raise RequestError(f"{field} must be true or false, got {shown(value)}")
    return value


def optional_choice(body: dict[str, Any], field: str, choices: tuple[str, ...]) -> str:
    """``body[field]``, one of ``choices`` (absent: the first)."""
    value = body.get(field, choices[0])
    if value not in choices:
        raise RequestError(f"{field} must be one of {', '.join(choices)}, got {shown(value)}")
    return value
