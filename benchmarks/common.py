"""Helpers every benchmark script shares: its ``--quick`` mode, what machine it ran on, how to
time a call, how to write a result, and which validation scenes a checkpoint is looked at on."""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from collections.abc import Callable
from datetime import datetime, timezone
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

from symgrasp.atomic import write_atomic

QUICK_DIR = Path("out/bench-quick")
"""Where ``--quick`` writes when given no folder."""

LOAD_AT_START = os.getloadavg()
"""The 1/5/15-minute load averages when the script started (it imports this module first)."""


def parse_args(
    parser: argparse.ArgumentParser, outputs: tuple[str, ...], quick: dict[str, Any], also: str = ""
) -> argparse.Namespace:
    """Parse a benchmark script's command line, with ``--quick [DIR]`` added: a smoke run in
    seconds through the script's real code, for the test that keeps every benchmark running
    (its numbers mean nothing). Quick mode gives the options in ``quick`` those values unless
    the command line sets them, and moves the ``outputs`` (options naming a file, stem or
    folder) into DIR under their default's name; setting one of those is an error, so a quick
    run never writes into benchmarks/results/ or docs/. ``also`` tells the help what else
    quick mode does. An option without a help text is refused: ``--help`` explains every
    option."""

    def option(dest: str) -> str:
        return "--" + dest.replace("_", "-")

    unexplained = [a.option_strings[0] if a.option_strings else a.dest
                   for a in parser._actions if not a.help]  # fmt: skip
    if unexplained:
        raise ValueError(f"give every option a help text; missing: {', '.join(unexplained)}")
    sizes = "; ".join(
        filter(None, [" ".join(f"{option(dest)} {value}" for dest, value in quick.items()), also])
    )
    parser.add_argument(
        "--quick",
        nargs="?",
        const=QUICK_DIR,
        type=Path,
        metavar="DIR",
        help="a smoke run in seconds, its numbers meaningless"
        + (f" ({sizes})" if sizes else "")
        + f"; writes every output under DIR (default: {QUICK_DIR}), never into "
        "benchmarks/results/ or docs/",
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


def add_result_option(parser: argparse.ArgumentParser, name: str) -> None:
    """``--result STEM``, where `write_result` writes, by default ``benchmarks/results/NAME``."""
    default = f"benchmarks/results/{name}"
    parser.add_argument(
        "--result",
        default=default,
        metavar="STEM",
        help="where the result goes: STEM.json (the numbers, the command, the machine and its "
        f"load) and STEM.md (its tables, if it has any) (default: {default})",
    )


def add_checkpoint_options(parser: argparse.ArgumentParser, scenes: int, threshold: str) -> None:
    """``--checkpoints``, ``--data``, ``--scenes`` and ``--threshold``: the checkpoints a script
    looks at, the validation scenes it looks at them on (`validation_items`) and the validity
    probability it cuts at (``threshold`` says what for)."""
    from symgrasp.config import DEFAULT_VALIDITY

    parser.add_argument("--checkpoints", nargs="+", default=["bingham2d-robotiq-2f85"],
                        help="checkpoint files or shipped model names (default: %(default)s)")  # fmt: skip
    parser.add_argument("--data", default=None,
                        help="dataset folder whose validation split is read (default: each "
                        "checkpoint's own training data)")  # fmt: skip
    parser.add_argument("--scenes", type=int, default=scenes,
                        help=f"validation scenes, spread evenly over the split (default: {scenes})")  # fmt: skip
    parser.add_argument("--threshold", type=float, default=DEFAULT_VALIDITY,
                        help=f"{threshold} (default: %(default)s)")  # fmt: skip


def per_checkpoint(
    args: argparse.Namespace, measure: Callable[[Path, list[dict[str, Any]], float], dict]
) -> list[dict[str, Any]]:
    """``measure(checkpoint, items, threshold)`` of each of ``args.checkpoints`` on its
    validation items (`validation_items`), with its name as ``model``."""
    cells = []
    for name in args.checkpoints:
        checkpoint, items = validation_items(name, args.data, args.scenes, args.quick)
        cells.append({**measure(checkpoint, items, args.threshold), "model": name})
    return cells


def validation_items(
    name: str, data: str | None, scenes: int, quick: bool
) -> tuple[Path, list[dict[str, Any]]]:
    """The checkpoint file of ``name`` (a path or a shipped model's name) and ``scenes`` items
    spread evenly over the validation split of ``data`` (None: the checkpoint's own training
    data), not augmented; in quick mode, synthetic scenes."""
    from symgrasp.detect.pretrained import resolve_model
    from symgrasp.model.checkpoint import load_checkpoint

    checkpoint = resolve_model(name)
    if quick:
        from symgrasp.model.synthetic import SyntheticGraspDataset

        split = SyntheticGraspDataset(scenes, seed=0)
    else:
        from symgrasp.data.dataset import GraspDataset

        data = data or load_checkpoint(checkpoint)["config"]["data"]
        split = GraspDataset(data, split="val", augment=False)
    step = max(1, len(split) // scenes)
    return checkpoint, [split[i] for i in range(0, len(split), step)][:scenes]


def cpu_model() -> str:
    """The CPU's model name from /proc/cpuinfo, else what `platform` knows."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def machine() -> dict[str, Any]:
    """What a number was measured on: the CPU and its logical cores, the platform, the versions
    of Python, torch and MuJoCo, torch's CPU threads (when the script imported torch), and the
    1/5/15-minute load averages when the script started and now (a timing on a shared 2-core
    machine means something only when the machine was idle)."""

    def installed(package: str) -> str | None:
        try:
            return version(package)
        except PackageNotFoundError:
            return None

    torch = sys.modules.get("torch")
    return {
        "cpu": cpu_model(),
        "logical_cpus": os.cpu_count(),
        "platform": platform.platform(),
        "python": platform.python_version(),
        "torch": installed("torch"),
        "mujoco": installed("mujoco"),
        "torch_threads": torch.get_num_threads() if torch is not None else None,
        "load_average_1_5_15min": {"start": LOAD_AT_START, "end": os.getloadavg()},
    }


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
    """Write ``stem.json``: what was measured, the command, ``fields``, the machine (with its
    load), the date and the ``cells``; and ``stem.md`` with the Markdown ``table`` when one is
    given."""
    result = {
        "benchmark": benchmark,
        "command": command,
        **fields,
        "machine": machine(),
        "date": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "cells": cells,
    }
    write_atomic(f"{stem}.json", lambda f: f.write(json.dumps(result, indent=1) + "\n"), mode="w")
    if table is not None:
        write_atomic(f"{stem}.md", lambda f: f.write(table), mode="w")


def percent_change(triple: list[float]) -> str:
    """A change of ratios and its interval, ``[change, low, high]``, as signed percent points:
    ``+6.1 [-3.6, +15.5]``."""
    point, low, high = (100 * v for v in triple)
    return f"{point:+.1f} [{low:+.1f}, {high:+.1f}]"
