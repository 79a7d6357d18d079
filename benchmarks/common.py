"""Helpers every benchmark script shares: what machine it ran on, how to time a call, and how
to write a result."""

from __future__ import annotations

import json
import platform
import time
from collections.abc import Callable
from datetime import datetime, timezone
from pathlib import Path
from typing import Any


def cpu_model() -> str:
    """The CPU's model name from /proc/cpuinfo, else what `platform` knows."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def best_seconds(run: Callable[[], object], repeats: int) -> float:
    """The fastest of ``repeats`` runs after a warm-up: on a shared machine, the least disturbed."""
    run()  # warm-up: caches, allocator
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return min(times)


def write_result(
    stem: str | Path,
    benchmark: str,
    command: str,
    cells: list[dict[str, Any]],
    table: str | None = None,
    **fields: Any,
) -> None:
    """Write ``stem.json``: what was measured, the command, ``fields``, the machine, the date
    and the ``cells``; and ``stem.md`` with the Markdown ``table`` when one is given."""
    result = {
        "benchmark": benchmark,
        "command": command,
        **fields,
        "machine": {"cpu": cpu_model(), "python": platform.python_version()},
        "date": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "cells": cells,
    }
    Path(f"{stem}.json").write_text(json.dumps(result, indent=1) + "\n")
    if table is not None:
        Path(f"{stem}.md").write_text(table)
