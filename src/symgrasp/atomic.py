"""Writing files so that a reader never sees half of one: temporary file, then rename."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import Any


def write_atomic(path: str | Path, write: Callable[[Any], object], mode: str = "wb") -> Path:
    """Call ``write(file)`` on a temporary file opened with ``mode`` next to ``path``, then
    rename it over ``path`` (an interrupted write leaves the previous file intact)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    with open(temporary, mode) as file:
        write(file)
    os.replace(temporary, path)
    return path
