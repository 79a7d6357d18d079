"""Helpers every benchmark script shares: its ``--quick`` mode, what machine it ran on, how to
time a call, and how to write a result."""

from __future__ import annotations

import argparse
import json
import platform
import time
from collections.abc import Callable
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from symgrasp.atomic import write_atomic

QUICK_DIR = Path("out/bench-quick")
"""Where ``--quick`` writes when given no folder."""


def parse_args(
    parser: argparse.ArgumentParser, outputs: tuple[str, ...], quick: dict[str, Any], also: str = ""
) -> argparse.Namespace:
    """Parse a benchmark script's command line, with ``--quick [DIR]`` added: a smoke run in
    seconds through the script's real code, for the test that keeps every benchmark running
    (its numbers mean nothing). Quick mode gives the options in ``quick`` those values unless
    the command line sets them, and moves the ``outputs`` (options naming a file, stem or
    folder) into DIR under their default's name; setting one of those is an error, so a quick
    run never writes into benchmarks/results/ or docs/. ``also`` tells the help what else
    quick mode does."""

    def option(dest: str) -> str:
        return "--" + dest.replace("_", "-")

    sizes = " ".join(f"{option(dest)} {value}" for dest, value in quick.items())
    parser.add_argument(
        "--quick",
        nargs="?",
        const=QUICK_DIR,
        type=Path,
        metavar="DIR",
        help=f"a smoke run in seconds, its numbers meaningless: {sizes}{also}; writes every "
        f"output under DIR (default: {QUICK_DIR}), never into benchmarks/results/ or docs/",
    )
    args = parser.parse_args()
    if args.quick:
        defaults = vars(parser.parse_args([]))
        for dest, value in quick.items():
            if getattr(args, dest) == defaults[dest]:
                setattr(args, dest, value)
        for dest in outputs:
            if getattr(args, dest) != defaults[dest]:
                parser.error(f"--quick writes its outputs under {args.quick}; drop {option(dest)}")
            setattr(args, dest, args.quick / Path(defaults[dest]).name)
        args.quick.mkdir(parents=True, exist_ok=True)
    return args


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
    write_atomic(f"{stem}.json", lambda f: f.write(json.dumps(result, indent=1) + "\n"), mode="w")
    if table is not None:
        write_atomic(f"{stem}.md", lambda f: f.write(table), mode="w")
