"""The grasp server's wire format, shared by the server and the client: HTTP + JSON, arrays as
nested lists or as base64 of their little-endian bytes (docs/serve.md is the reference).

This module needs only the standard library and numpy, so that the client
(`symgrasp.serve.client`) runs in a robot's process without torch. The paths, the port and the
version are `symgrasp.serve`'s names.
"""

from __future__ import annotations

import base64
import binascii
import math
from typing import Any

import numpy as np

from symgrasp.serve import DEFAULT_PORT, DETECT_PATH, HEALTH_PATH, PROTOCOL

MAX_BODY = 256 * 2**20
"""[bytes] the largest request accepted (eight 1280 × 720 float32 depth images in base64 take
about 40 MB)."""

DTYPES = {"float32": "<f4", "float64": "<f8", "uint16": "<u2"}
"""The element types an encoded array may have (little-endian, whatever the machine)."""


__all__ = [
    "DEFAULT_PORT", "DETECT_PATH", "DTYPES", "HEALTH_PATH", "MAX_BODY", "PROTOCOL",
    "RequestError", "decode_array", "encode_array",
]  # fmt: skip


class RequestError(ValueError):
    """A request the server refuses (HTTP 400); the message names the field and what was
    expected."""


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
    """The array of a request's ``field``: nested lists of numbers (read as float64), or the
    encoded form of `encode_array` with a dtype among ``dtypes``. `RequestError` naming the
    field for anything else."""
    if isinstance(value, dict):
        return _decode_encoded(value, field, dtypes)
    if not isinstance(value, list):
        raise RequestError(
            f"{field} must be an array: nested lists of numbers or "
            f'{{"dtype", "shape", "data"}}, got {type(value).__name__}'
        )
    try:
        array = np.array(value, dtype=np.float64)
    except (ValueError, TypeError) as error:
        raise RequestError(
            f"{field} must be nested lists of numbers of one rectangular shape ({error})"
        ) from None
    return array


def _decode_encoded(value: dict[str, Any], field: str, dtypes: tuple[str, ...]) -> np.ndarray:
    missing = [key for key in ("dtype", "shape", "data") if key not in value]
    if missing:
        raise RequestError(
            f"{field} lacks {', '.join(missing)} (an encoded array has dtype, shape, data)"
        )
    name, shape, data = value["dtype"], value["shape"], value["data"]
    if name not in dtypes:
        raise RequestError(f"{field}.dtype must be one of {', '.join(dtypes)}, got {name!r}")
    if not (
        isinstance(shape, list)
        and all(isinstance(n, int) and not isinstance(n, bool) and n >= 0 for n in shape)
    ):
        raise RequestError(f"{field}.shape must be a list of sizes ≥ 0, got {shape!r}")
    if not isinstance(data, str):
        raise RequestError(f"{field}.data must be a base64 string, got {type(data).__name__}")
    try:
        raw = base64.b64decode(data, validate=True)
    except (binascii.Error, ValueError) as error:
        raise RequestError(f"{field}.data is not base64 ({error})") from None
    itemsize = np.dtype(DTYPES[name]).itemsize
    expected = math.prod(shape) * itemsize
    if len(raw) != expected:
        raise RequestError(
            f"{field}.data holds {len(raw)} bytes; shape {shape} of {name} needs {expected}"
        )
    return np.frombuffer(raw, dtype=DTYPES[name]).reshape(shape).astype(name)


def optional_number(body: dict[str, Any], field: str, low: float, high: float) -> float | None:
    """``body[field]`` as a float in [low, high], or None when absent or null."""
    value = body.get(field)
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int | float) or not low <= value <= high:
        raise RequestError(f"{field} must be a number in [{low:g}, {high:g}], got {value!r}")
    return float(value)


def optional_integer(body: dict[str, Any], field: str, low: int, high: int) -> int | None:
    """``body[field]`` as an int in [low, high], or None when absent or null."""
    value = body.get(field)
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise RequestError(f"{field} must be an integer in [{low}, {high}], got {value!r}")
    return value


def optional_flag(body: dict[str, Any], field: str) -> bool:
    """``body[field]`` as a bool (absent: False)."""
    value = body.get(field, False)
    if not isinstance(value, bool):
        raise RequestError(f"{field} must be true or false, got {value!r}")
    return value


def optional_choice(body: dict[str, Any], field: str, choices: tuple[str, ...]) -> str:
    """``body[field]``, one of ``choices`` (absent: the first)."""
    value = body.get(field, choices[0])
    if value not in choices:
        raise RequestError(f"{field} must be one of {', '.join(choices)}, got {value!r}")
    return value
