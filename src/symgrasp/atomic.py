"""Writing files so that a reader never sees half of one: temporary file, then rename. Every
rename of something the package wrote happens here (a test checks it). Reading back the JSON
records so written (`read_json`): a hand-edited or torn one is one error naming the file."""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any


def write_atomic(
    path: str | Path, write: Callable[[Any], object], mode: str = "wb", **open_options: Any
) -> Path:
    """Call ``write(file)`` on a temporary file opened with ``mode`` (and ``open_options``, e.g.
    ``newline=""``) next to ``path``, then rename it over ``path``: an interrupted write
    leaves the previous file intact."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with open(temporary, mode, **open_options) as file:
            write(file)
        os.replace(temporary, path)
    finally:
        temporary.unlink(missing_ok=True)
    return path


def write_csv(path: str | Path, rows: list[dict[str, Any]]) -> Path:
    """``rows`` as CSV with a header of every key in first-seen order (a row without a key
    leaves its cell empty), written atomically."""
    import csv

    columns = list(dict.fromkeys(key for row in rows for key in row))

    def write(file: Any) -> None:
        writer = csv.DictWriter(file, fieldnames=columns)
        writer.writeheader()
        writer.writerows(rows)

    return write_atomic(path, write, "w", newline="")


def move_into_place(source: str | Path, path: str | Path) -> Path:
    """Rename ``source``, a file or folder finished elsewhere in pieces (a resumable download,
    an extracted archive), to ``path`` in one step: a reader sees all of it or nothing. For a
    folder ``path`` must not exist; a file replaces any file there."""
    os.replace(source, path)
    return Path(path)


def read_json(path: str | Path, what: str, kind: type = dict, keys: tuple[str, ...] = ()) -> Any:
    """The JSON value of the file ``path``, a ``what`` (e.g. "dataset manifest"): of the type
    ``kind`` (dict: a JSON object, list: an array) and, for an object, holding ``keys``. Raises
    ValueError ``"{path} is not a valid {what}: …"`` saying what was expected otherwise."""
    try:
        value = json.loads(Path(path).read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as err:
        raise ValueError(f"{path} is not a valid {what}: not JSON ({err})") from None
    return check_json(value, path, what, kind, keys)


def check_json(
    value: Any, path: str | Path, what: str, kind: type = dict, keys: tuple[str, ...] = ()
) -> Any:
    """``value``, read from ``path``, when it is a ``what`` of the type ``kind`` holding
    ``keys`` (`read_json`); ValueError naming the file and what was expected otherwise."""
    names = {dict: "a JSON object", list: "a JSON array"}
    if not isinstance(value, kind):
        raise ValueError(
            f"{path} is not a valid {what}: expected {names.get(kind, kind.__name__)}, got "
            f"{json.dumps(value)[:40]}"
        )
    missing = [key for key in keys if key not in value]
    if missing:
        raise ValueError(
            f"{path} is not a valid {what}: it lacks the key{'s' * (len(missing) > 1)} "
            f"{', '.join(map(repr, missing))}"
        )
    return value
