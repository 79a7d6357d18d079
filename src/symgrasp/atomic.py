"""Writing files so that a reader never sees half of one: temporary file, then rename. Every
rename of something the package wrote happens here (a test checks it)."""

from __future__ import annotations

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
