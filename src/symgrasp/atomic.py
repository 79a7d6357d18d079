"""Writing files so that a reader never sees half of one: temporary file, then rename."""

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
    leaves the previous file intact. The only rename of a written file in the package."""
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
