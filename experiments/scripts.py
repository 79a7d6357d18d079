"""What the scripts of benchmarks/ and experiments/ share: their ``--quick`` mode, where their
outputs go unless ``--publish`` is given, how they stop when the data a user downloads is
missing, what machine a number was measured on, how to time a call, and how to write a result.

The lab's helper, outside the installed package: the experiments import it by its bare name
(``scripts``, beside them), the benchmarks and the tests as ``experiments.scripts``. A script
imports it before it does any work (its `LOAD_AT_START` is the machine's load when the script
started) and ends with ``run_main(main)``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shlex
import shutil
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

ROOT = Path(__file__).resolve().parents[1]
"""The checkout's root (this file is experiments/scripts.py), where the scripts run from."""

OUT = Path("out")
"""Where a run without ``--publish`` writes what it would publish: each output under OUT at the
path it is published at (experiments/results/NAME → out/experiments/results/NAME), so that a
run leaves the committed results and docs/ as they were."""

QUICK_DIR = OUT / "bench-quick"
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
    parser: argparse.ArgumentParser,
    outputs: tuple[str, ...],
    quick: dict[str, Any],
    also: str = "",
    pages: tuple[str, ...] = (),
) -> argparse.Namespace:
    """Parse a script's command line, with ``--publish`` and ``--quick [DIR]`` added. The
    ``outputs`` (options naming a file, stem or folder) left at their defaults go where
    `output_path` says: under `OUT` unless ``--publish`` is given. ``pages`` are outputs the
    script edits in place (a page's text between markers): a copy of the published page is put
    where the run writes it. Quick mode is a smoke run in seconds through the script's real
    code, for the test that keeps every script running (its numbers mean nothing): it gives the
    options in ``quick`` those values unless the command line sets them, and moves the outputs
    into DIR; setting one of those, or ``--publish``, is an error there. ``also`` tells the help
    what else quick mode does. An option without a help text is refused (ValueError naming it):
    ``--help`` explains every option."""

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
        "--publish",
        action="store_true",
        help="write the outputs left at their defaults where they are published, into the "
        f"committed results and docs/ (without it: under {OUT}/, at the same paths)",
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
    actions = {action.dest: action for action in parser._actions}

    def default(dest: str) -> Any:  # as parsing gives it: a string default through its type
        value = parser.get_default(dest)
        kind = actions[dest].type
        return kind(value) if isinstance(value, str) and callable(kind) else value

    if args.quick:
        if args.publish:
            parser.error("--quick never publishes; drop --publish")
        for dest, value in quick.items():
            if getattr(args, dest) == default(dest):
                setattr(args, dest, value)
        for dest in outputs:
            if getattr(args, dest) != default(dest):
                parser.error(f"--quick writes its outputs under {args.quick}; drop {option(dest)}")
        args.quick.mkdir(parents=True, exist_ok=True)
    for dest in outputs:
        if default(dest) is None or getattr(args, dest) != default(dest):
            continue  # none (the script names it), or given: written where it says
        published = parser.get_default(dest)
        path = output_path(published, args)
        if path == Path(published):
            continue
        path.parent.mkdir(parents=True, exist_ok=True)
        if dest in pages:
            shutil.copyfile(published, path)
        setattr(args, dest, path)
    return args


def output_path(published: str | Path, args: argparse.Namespace) -> Path:
    """Where this run (``args`` of `parse_args`) writes an output published at ``published``:
    in quick mode under DIR by its name; with ``--publish``, or when it lies under `OUT` already
    (a work folder), there; else under `OUT` at its path from the checkout's root."""
    published = Path(published)
    if args.quick:
        return args.quick / published.name
    relative = published.resolve().relative_to(ROOT) if published.is_absolute() else published
    if args.publish or relative.parts[:1] == OUT.parts:
        return published
    return OUT / relative


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
    made it, options included. The environment words ``env``, ``python``, the script's path and
    its arguments, quoted for a shell; every absolute path among them relative to the checkout's
    root, where the command runs (`from_checkout`), so that a result names no machine's
    folders."""
    script = os.path.relpath(Path(sys.argv[0]).resolve(), ROOT)
    words = shlex.join(["python", script, *map(from_checkout, sys.argv[1:])])
    return " ".join([*map(from_checkout, env.split()), words])


def from_checkout(word: str) -> str:
    """``word`` of a command line with its absolute paths relative to the checkout's root: the
    word, or its value after the first ``=`` (``--out=/x``, ``PYTHONPATH=/a:/b``), each of its
    ``:``-separated parts. A URL is left as it is."""
    if "://" in word:
        return word
    name, sep, value = word.partition("=") if "=" in word else ("", "", word)
    parts = (os.path.relpath(p, ROOT) if os.path.isabs(p) else p for p in value.split(os.pathsep))
    return name + sep + os.pathsep.join(parts)


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
