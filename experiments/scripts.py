"""What the scripts of benchmarks/ and experiments/ share: their ``--quick`` mode, how they stop
when the data a user downloads is missing, what machine a number was measured on, how to time a
call, and how to write a result.

The scripts are not part of the package; this module is, so that both folders (and the tests)
import one definition. A script imports it before it does any work (its `LOAD_AT_START` is the
machine's load when the script started) and ends with ``run_main(main)``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shlex
import sys
import time
from collections.abc import Callable
from datetime import datetime, timezone
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

from symgrasp.atomic import write_atomic
from symgrasp.objects.folder import EX_NOINPUT, MissingData
from symgrasp.parallel import TasksFailed

QUICK_DIR = Path("out/bench-quick")
"""Where ``--quick`` writes when given no folder."""

EX_UNAVAILABLE = 69
"""The exit status of a script that needs an optional extra not installed (sysexits.h: "a
support program does not exist"), so that a caller (the tests) tells it from a failure."""

LOAD_AT_START = os.getloadavg()
"""The 1/5/15-minute load averages when the script started (it imports this module first)."""


def run_main(main: Callable[[], None]) -> None:
    """Run a script's ``main``. Data it needs that is not there (`MissingData`: an object set,
    the reference hands) stops it with one line on stderr naming what is missing and how to get
    it, and exit status `EX_NOINPUT`; an optional extra not installed (the ModuleNotFoundError
    that names it, e.g. `symgrasp.parallel.cluster.import_ray`) with its one line and
    `EX_UNAVAILABLE`; tasks that failed (`TasksFailed`: e.g. rounds of a benchmark) with one line
    naming the first cause and exit status 1. Never a traceback for these."""
    try:
        main()
    except (MissingData, TasksFailed) as error:
        print(f"error: {error}", file=sys.stderr)
        sys.exit(EX_NOINPUT if isinstance(error, MissingData) else 1)
    except ModuleNotFoundError as error:
        if error.name is not None:  # raised by an import itself, not by a check naming an extra
            raise
        print(f"error: {error}", file=sys.stderr)
        sys.exit(EX_UNAVAILABLE)


def parse_args(
    parser: argparse.ArgumentParser, outputs: tuple[str, ...], quick: dict[str, Any], also: str = ""
) -> argparse.Namespace:
    """Parse a script's command line, with ``--quick [DIR]`` added: a smoke run in seconds
    through the script's real code, for the test that keeps every script running (its numbers
    mean nothing). Quick mode gives the options in ``quick`` those values unless the command
    line sets them, and moves the ``outputs`` (options naming a file, stem or folder) into DIR
    under their default's name; setting one of those is an error, so a quick run never writes
    into the committed results or docs/. ``also`` tells the help what else quick mode does. An
    option without a help text is refused (ValueError naming it): ``--help`` explains every
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
        + f"; writes every output under DIR (default: {QUICK_DIR}), never into the committed "
        "results or docs/",
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


def command_line(env: str = "PYTHONPATH=src") -> str:
    """The command that ran this script, for its result: a result's command must be the one that
    made it, options included. The environment words ``env`` as they are, ``python``, the
    script's path from the checkout's root (where the command runs; as given when it lies
    elsewhere) and its arguments, quoted for a shell."""
    script = Path(sys.argv[0])
    root = Path(__file__).resolve().parents[2]  # this file is src/symgrasp/scripts.py
    if script.resolve().is_relative_to(root):
        script = script.resolve().relative_to(root)
    return " ".join(filter(None, [env, shlex.join(["python", str(script), *sys.argv[1:]])]))


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
