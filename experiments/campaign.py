"""Run a plan of long commands (datasets, training runs, benchmarks) that outlives any session.

    PYTHONPATH=src python experiments/campaign.py run PLAN.toml [PLAN.toml ...] [--root DIR] [--cores 2] [--bank DIR] [--first NAME ...]
    PYTHONPATH=src python experiments/campaign.py status PLAN.toml [PLAN.toml ...] [--root DIR] [--bank DIR]
    PYTHONPATH=src python experiments/campaign.py show PLAN.toml [PLAN.toml ...] [--root DIR]
    PYTHONPATH=src python experiments/campaign.py run --quick [DIR]

A plan is a TOML file of steps, each a shell command with the cores it uses and the steps it
needs (``experiments/campaigns/*.toml``)::

    [vars]                      # {name} in a command; --root sets {root}
    data = "{root}/data/vgn-robotiq"

    [[step]]
    name = "data-robotiq"
    cores = 2
    run = "symgrasp data generate ... --out {data} --resume"

    [[step]]
    name = "lc-900-s0"
    needs = ["data-robotiq"]
    cores = 1                   # OMP_NUM_THREADS of the command
    run = "symgrasp train --data {data} ... --resume"

Several plan files make one plan, in order: a later file uses the vars of the earlier ones and
its steps may need theirs (a campaign built on another's runs). ``run`` starts every step
whose needs are done, in the plan's order, as long as their cores fit
in ``--cores`` (the steps ``--first`` names, shell-style patterns, before the others, each
group in the plan's order: a decision waiting on them is reached sooner), and returns when
nothing more can start. A step is done when it exited 0 with
the same command: ``ROOT/done/NAME`` holds the command it finished, so an edited command runs
again. Every command must resume its own work (symgrasp's ``--resume``), because a session's
end kills whatever runs: the next ``run`` starts those steps again and they continue where they
stopped. A failed step is recorded in ``ROOT/failed/NAME`` (exit code, time) and run again by the
next ``run``; the steps needing it wait. A running step has ``ROOT/running/NAME`` (its process
id, the boot and tick it started at, its start time): ``status`` tells a running step from one
whose driver was killed (a process id reused after a restart included), and a second ``run``
on the same root while the first still runs a step is refused. Output goes to
``ROOT/logs/NAME.log``. ``show`` prints the steps as ``run`` would start them, their vars filled
in, one JSON object a line (``name``, ``cores``, ``needs``, ``keep``, ``run``). ``--quick`` runs
a four-step plan of Python one-liners (one failing) twice and writes ``campaign.json``.

**The bank: a campaign that outlives its machine.** A root is no safer than the disk it is on,
and a development machine can be replaced between sessions with everything that was not
committed. With ``--bank DIR`` (a folder of the repository, committed at each stop) every step
that finishes leaves its record there, ``DIR/NAME/record.json`` (its command, ``{root}`` in place
of the root, and the SHA-256 of each kept file), with copies of the files its ``keep`` patterns match under the root
(``DIR/NAME/files/…``)::

    [[step]]
    name = "select-s0"
    needs = ["train-s0"]
    run = "symgrasp select {runs}/s0 ..."
    keep = ["runs/s0/best.pt", "runs/s0/selection.json", "bench/s0/**", "!bench/s0/**/*.log"]

A pattern is a path relative to the root (or under ``{root}``) whose ``*`` and ``?`` stay within
one folder and whose ``**`` spans folders; one that starts with ``!`` leaves out what it
matches. A step finishes only when each of its patterns matches a file. On a root without a
step's done marker, ``run`` restores a banked step whose command is unchanged and whose copies
still have their recorded hashes (its files back in the root, the marker written) and does not
run it. A banked step that keeps nothing (a dataset too large to commit) counts as done while
nothing still to run needs it; when a step to run does, it runs again (its command's own
resume and fixed seeds make the same outputs): so a plan should keep, on the steps that end a
chain, whatever a later step or the report reads.
"""

from __future__ import annotations

import argparse
import datetime
import fnmatch
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from symgrasp.atomic import write_atomic
from symgrasp.digest import file_sha256
from symgrasp.scripts import command_line, parse_args, run_main, write_result

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

POLL_SECONDS = 1.0


@dataclass(frozen=True)
class Step:
    """One command of a plan."""

    name: str
    run: str
    plan: Path
    """The file that defines it."""
    cores: int = 1
    needs: tuple[str, ...] = field(default=())
    keep: tuple[str, ...] = field(default=())
    """Patterns of the files under the root that the bank keeps (the module docstring)."""


def read_plan(paths: list[Path], root: Path) -> list[Step]:
    """The steps of the plan files ``paths``, in order, with ``{root}`` and their ``[vars]``
    filled in. A later file sees the vars of the earlier ones (and may not define them again)
    and its steps may need theirs: a campaign that builds on another's runs is a second file."""
    values, defined_in = {"root": str(root)}, {}
    steps: list[Step] = []
    for path in paths:
        try:
            plan = tomllib.loads(path.read_text())
        except (OSError, tomllib.TOMLDecodeError) as error:
            raise SystemExit(f"error: plan {path}: {error}") from None
        for key, value in plan.get("vars", {}).items():
            if key in values:
                where = defined_in.get(key, "--root")
                raise SystemExit(f"error: plan {path}: var {key!r} is already defined by {where}")
            # one line, as a step's command: a line break inside a shell command would end it
            values[key] = " ".join(str(value).split()).format(**values)
            defined_in[key] = str(path)
        steps += _steps(path, plan, values)
    names = [step.name for step in steps]
    for step in steps:
        missing = [need for need in step.needs if need not in names[: names.index(step.name)]]
        if missing:
            raise SystemExit(
                f"error: plan {step.plan}: step {step.name!r} needs {missing}, which are not "
                "steps listed before it"
            )
    repeated = sorted({name for name in names if names.count(name) > 1})
    if repeated:
        raise SystemExit(f"error: plan {', '.join(map(str, paths))}: step names repeat: "
                         f"{', '.join(repeated)}")  # fmt: skip
    return steps


def _steps(path: Path, plan: dict[str, Any], values: dict[str, str]) -> list[Step]:
    """The steps of one plan file, their commands filled in from ``values``."""
    steps = []
    for entry in plan.get("step", []):
        unknown = set(entry) - {"name", "run", "cores", "needs", "keep"}
        if unknown or not {"name", "run"} <= set(entry):
            raise SystemExit(
                f"error: plan {path}: step {entry.get('name', '?')!r} needs 'name' and 'run' "
                f"and may have 'cores', 'needs', 'keep'; got {sorted(entry)}"
            )
        try:
            run = " ".join(entry["run"].split()).format(**values)
            keep = tuple(_relative(pattern.format(**values), values["root"], path, entry["name"])
                         for pattern in entry.get("keep", ()))  # fmt: skip
        except KeyError as error:
            raise SystemExit(f"error: plan {path}: step {entry['name']!r} uses {error}, "
                             f"which [vars] does not define") from None  # fmt: skip
        steps.append(Step(entry["name"], run, path, int(entry.get("cores", 1)),
                          tuple(entry.get("needs", ())), keep))  # fmt: skip
    return steps


def _relative(pattern: str, root: str, plan: Path, name: str) -> str:
    """A keep pattern relative to the root (``!`` kept in front)."""
    exclude, body = ("!", pattern[1:]) if pattern.startswith("!") else ("", pattern)
    if body.startswith(root + "/"):
        body = body[len(root) + 1 :]
    if not body or body.startswith("/") or ".." in body.split("/"):
        raise SystemExit(f"error: plan {plan}: step {name!r} keeps {pattern!r}, which is not a "
                         "path under the root")  # fmt: skip
    return exclude + body


def _pattern(glob: str) -> re.Pattern[str]:
    """``glob`` as a regular expression over POSIX paths: ``**`` any folders, ``*`` and ``?``
    within one."""
    parts = re.split(r"(\*\*/?|\*|\?)", glob)
    wild = {"**/": "(?:.*/)?", "**": ".*", "*": "[^/]*", "?": "[^/]"}
    return re.compile("".join(wild.get(part, re.escape(part)) for part in parts))


def kept_files(step: Step, root: Path) -> list[str]:
    """The files under ``root`` that ``step.keep`` matches, relative and sorted.

    Raises:
        SystemExit: a pattern (not ``!``) matches no file.
    """
    files = sorted(path.relative_to(root).as_posix() for path in root.rglob("*")
                   if path.is_file() and not path.is_symlink())  # fmt: skip
    chosen: set[str] = set()
    for pattern in step.keep:
        if pattern.startswith("!"):
            left_out = _pattern(pattern[1:])
            chosen -= {f for f in chosen if left_out.fullmatch(f)}
            continue
        kept = _pattern(pattern)
        matched = {f for f in files if kept.fullmatch(f)}
        if not matched:
            raise SystemExit(f"step {step.name!r} keeps {pattern!r}, which matches no file "
                             f"under {root}")  # fmt: skip
        chosen |= matched
    return sorted(chosen)


def _copy(source: Path, target: Path) -> None:
    """Copy ``source`` to ``target`` atomically."""
    with open(source, "rb") as original:
        write_atomic(target, lambda file: shutil.copyfileobj(original, file))


def deposit(step: Step, root: Path, bank: Path) -> None:
    """Bank ``step``: its record and copies of its kept files, replacing any earlier ones."""
    files = kept_files(step, root)
    staging, old = bank / f".{step.name}.tmp", bank / f".{step.name}.old"
    for folder in (staging, old):
        shutil.rmtree(folder, ignore_errors=True)
    for name in files:
        _copy(root / name, staging / "files" / name)
    record = {"run": _rooted(step, root), "banked": _now().isoformat(),
              "files": {name: file_sha256(staging / "files" / name) for name in files}}  # fmt: skip
    staging.mkdir(parents=True, exist_ok=True)
    (staging / "record.json").write_text(json.dumps(record, indent=1) + "\n")
    if (bank / step.name).exists():
        os.replace(bank / step.name, old)
    os.replace(staging, bank / step.name)
    shutil.rmtree(old, ignore_errors=True)


def _rooted(step: Step, root: Path) -> str:
    """``step``'s command as the bank records it: ``{root}`` for the root, which another
    machine may place elsewhere."""
    return step.run.replace(str(root), "{root}")


def banked(step: Step, root: Path, bank: Path | None) -> dict[str, str] | None:
    """The kept files (name → SHA-256) of ``step``'s record in ``bank``, or None where there
    is none for its command, or a copy lacks or differs from its recorded hash."""
    record_path = None if bank is None else bank / step.name / "record.json"
    if record_path is None or not record_path.is_file():
        return None
    record = json.loads(record_path.read_text())
    if record.get("run") != _rooted(step, root):
        return None
    files = record["files"]
    for name, digest in files.items():
        copy = bank / step.name / "files" / name
        if not copy.is_file() or file_sha256(copy) != digest:
            print(f"bank: {copy} is missing or not the file its record names; "
                  f"{step.name} is not restored", flush=True)  # fmt: skip
            return None
    return files


def withdraw(step: Step, files: dict[str, str], root: Path, bank: Path) -> None:
    """Put ``step``'s banked files back under ``root`` and mark it done."""
    for name, digest in files.items():
        target = root / name
        if not (target.is_file() and file_sha256(target) == digest):
            _copy(bank / step.name / "files" / name, target)
    _mark(root / "done", step.name, step.run)


def is_done(step: Step, root: Path) -> bool:
    marker = root / "done" / step.name
    return marker.exists() and marker.read_text() == step.run


def _now() -> datetime.datetime:
    return datetime.datetime.now(datetime.timezone.utc).replace(microsecond=0)


def _identity(pid: int) -> str:
    """Who process ``pid`` is: the boot and the process's start (clock ticks after boot), so a
    process id reused after a restart is not taken for the step; ``-`` where /proc is missing."""
    try:
        boot = Path("/proc/sys/kernel/random/boot_id").read_text().strip()
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return "-"
    return f"{boot}:{stat[stat.rindex(')') + 2 :].split()[19]}"  # field 22, starttime


def _alive(pid: int, identity: str) -> bool:
    """Whether the process a running marker names still runs."""
    if identity != "-":
        return _identity(pid) == identity
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # someone else's process
        return True
    return True


def _running(root: Path) -> dict[str, tuple[int, str, str]]:
    """The steps with a running marker: name → (process id, its identity, start time)."""
    markers = {}
    for marker in sorted((root / "running").glob("[!.]*")):
        fields = marker.read_text().split()
        if len(fields) != 3 or not fields[0].isdigit():
            raise SystemExit(f"error: running marker {marker} holds {' '.join(fields)!r}, not "
                             "'PID IDENTITY STARTED'; delete it if its step is not running")  # fmt: skip
        markers[marker.name] = (int(fields[0]), fields[1], fields[2])
    return markers


def _mark(folder: Path, name: str, text: str) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    temporary = folder / f".{name}.tmp"
    temporary.write_text(text)
    os.replace(temporary, folder / name)


def _to_run_again(steps: list[Step], outcome: dict[str, str], resting: set[str]) -> set[str]:
    """The banked steps in ``resting`` (nothing of theirs in the root) that a step still to run
    needs, directly or through another such step."""
    by_name = {step.name: step for step in steps}
    wanted: set[str] = set()
    waiting = [step for step in steps if step.name not in outcome and step.name not in resting]
    while waiting:
        for need in waiting.pop().needs:
            if need in resting and need not in wanted:
                wanted.add(need)
                waiting.append(by_name[need])
    return wanted


def first(steps: list[Step], patterns: list[str]) -> list[Step]:
    """``steps`` with those whose name matches one of ``patterns`` (`fnmatch`) moved to the
    front, each group in its own order."""
    named = [s for s in steps if any(fnmatch.fnmatchcase(s.name, p) for p in patterns)]
    return named + [s for s in steps if s not in named]


def run(steps: list[Step], root: Path, cores: int, bank: Path | None = None) -> dict[str, str]:
    """Run the plan's missing steps (see the module docstring); each step's outcome."""
    for name, (pid, identity, started) in _running(root).items():
        if _alive(pid, identity):
            raise SystemExit(f"error: step {name!r} is still running (process {pid}, started "
                             f"{started}): another campaign.py runs on {root}; stop it first")  # fmt: skip
        (root / "running" / name).unlink()  # its driver was killed: the step resumes below
    resting = set()
    for step in steps:
        files = None if is_done(step, root) else banked(step, root, bank)
        if files is not None and step.keep:
            withdraw(step, files, root, bank)
            print(f"{step.name}: restored from {bank}", flush=True)
        elif files is not None:
            resting.add(step.name)
    outcome = {step.name: "done" for step in steps if is_done(step, root)}
    again = _to_run_again(steps, outcome, resting)
    outcome |= {name: "banked" for name in resting - again}
    running: dict[str, tuple[Step, subprocess.Popen, datetime.datetime]] = {}
    (root / "logs").mkdir(parents=True, exist_ok=True)
    while True:
        for name, (step, process, started) in list(running.items()):
            if process.poll() is None:
                continue
            del running[name]
            now = _now()
            kept = process.returncode == 0 and _deposit_or_why(step, root, bank)
            if kept is True:
                _mark(root / "done", name, step.run)
                (root / "failed" / name).unlink(missing_ok=True)
                outcome[name] = "done"
            elif kept:
                _mark(root / "failed", name, f"{kept} at {now.isoformat()}\n")
                outcome[name] = f"failed ({kept})"
            else:
                _mark(root / "failed", name, f"exit {process.returncode} at {now.isoformat()}\n")
                outcome[name] = f"failed (exit {process.returncode})"
            (root / "running" / name).unlink(missing_ok=True)
            minutes = (now - started).total_seconds() / 60
            print(f"{now.isoformat()} {name}: {outcome[name]} after {minutes:.0f} min", flush=True)
        free = cores - sum(step.cores for step, _, _ in running.values())
        for step in steps:
            ready = all(outcome.get(need) == "done" for need in step.needs)
            if step.name in outcome or step.name in running or not ready or step.cores > free:
                continue
            log = open(root / "logs" / f"{step.name}.log", "a")  # the child's output
            log.write(f"\n$ {step.run}\n")
            log.flush()
            environment = {**os.environ, "OMP_NUM_THREADS": str(step.cores)}
            process = subprocess.Popen(step.run, shell=True, stdout=log, stderr=subprocess.STDOUT,
                                       env=environment, start_new_session=True)  # fmt: skip
            log.close()
            started = _now()
            marker = f"{process.pid} {_identity(process.pid)} {started.isoformat()}\n"
            _mark(root / "running", step.name, marker)
            running[step.name] = (step, process, started)
            free -= step.cores
            print(f"started {step.name} ({step.cores} cores): {step.run}", flush=True)
        if not running:
            break
        time.sleep(POLL_SECONDS)
    for step in steps:
        outcome.setdefault(step.name, "waiting (a step it needs failed)")
    return outcome


def _deposit_or_why(step: Step, root: Path, bank: Path | None) -> bool | str:
    """Bank a step that exited 0: True, or why it could not (a keep pattern matched nothing)."""
    if bank is None:
        return True
    try:
        deposit(step, root, bank)
    except SystemExit as error:
        return str(error)
    return True


def status(steps: list[Step], root: Path, bank: Path | None = None) -> dict[str, str]:
    """Each step's state on disk: done, banked, running, stopped with its driver, failed, or
    not yet."""
    states, running = {}, _running(root)
    for step in steps:
        failed = root / "failed" / step.name
        if is_done(step, root):
            states[step.name] = "done"
        elif banked(step, root, bank) is not None:
            states[step.name] = ("banked: the next run restores it" if step.keep else
                                 "banked: runs again only if a step to run needs it")  # fmt: skip
        elif step.name in running:
            pid, identity, started = running[step.name]
            states[step.name] = (f"running since {started} (process {pid})"
                                 if _alive(pid, identity) else
                                 f"stopped (started {started}; its driver was killed): the "
                                 "next run resumes it")  # fmt: skip
        elif failed.exists():
            states[step.name] = "failed: " + failed.read_text().strip()
        else:
            states[step.name] = "to do"
    return states


QUICK_PLAN = """
[vars]
py = "{python}"
[[step]]
name = "first"
run = "{{py}} -c 'open(\\"{{root}}/first.txt\\", \\"w\\").write(\\"1\\")'"
[[step]]
name = "second"
needs = ["first"]
cores = 2
run = "{{py}} -c 'print(open(\\"{{root}}/first.txt\\").read())'"
[[step]]
name = "broken"
run = "{{py}} -c 'raise SystemExit(3)'"
[[step]]
name = "after-broken"
needs = ["broken"]
run = "{{py}} -c 'print(1)'"
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("action", nargs="?", default="run", choices=("run", "status", "show"),
                        help="run the plan (default), list its steps' state, or show its steps "
                        "as JSON lines, their vars filled in")  # fmt: skip
    parser.add_argument("plan", nargs="*", type=Path,
                        help="the plan's TOML files: a later file may use the vars and need "
                        "the steps of an earlier one")  # fmt: skip
    parser.add_argument("--root", type=Path, default=Path("out/campaign"),
                        help="folder of the plan's outputs, logs and markers ({root} in commands; "
                        "default: out/campaign)")  # fmt: skip
    parser.add_argument("--cores", type=int, default=os.cpu_count() or 1,
                        help="cores the running steps may use together (default: all)")  # fmt: skip
    parser.add_argument("--bank", type=Path, default=None,
                        help="folder (in the repository, committed) that keeps each finished "
                        "step's record and the files its 'keep' patterns match; a root without "
                        "them takes them back from it (default: no bank)")  # fmt: skip
    parser.add_argument("--first", nargs="+", default=[], metavar="NAME",
                        help="steps (shell-style patterns: 'noback-*') that run tries before the "
                        "others when cores free up, in the plan's order; their needs still hold "
                        "(default: the plan's order alone)")  # fmt: skip
    args = parse_args(
        parser,
        outputs=("root",),
        quick={},
        also="a plan of four one-liners, one failing, run twice",
    )
    if args.quick:
        args.plan = [args.quick / "plan.toml"]
        args.plan[0].write_text(QUICK_PLAN.format(python=shlex.quote(sys.executable)))
    elif not args.plan:
        parser.error("the plan's TOML file is needed")
    root = args.root.resolve()
    steps = read_plan(args.plan, root)
    for pattern in args.first:
        if not any(fnmatch.fnmatchcase(step.name, pattern) for step in steps):
            parser.error(f"--first: {pattern!r} names no step of the plan")
    steps = first(steps, args.first)
    bank = None if args.bank is None else args.bank.resolve()
    if args.action == "status":
        for name, state in status(steps, root, bank).items():
            print(f"{name:30s} {state}")
        return
    if args.action == "show":
        for step in steps:
            print(json.dumps({"name": step.name, "cores": step.cores, "needs": list(step.needs),
                              "keep": list(step.keep), "run": step.run}))  # fmt: skip
        return
    outcome = run(steps, root, args.cores, bank)
    if args.quick:  # again: only what failed runs
        again = run(steps, root, args.cores)
        write_result(args.quick / "campaign", "campaign driver, quick plan", command_line(""), [],
                     steps={"first run": outcome, "second run": again})  # fmt: skip
        return
    failed = [name for name, state in outcome.items() if state not in ("done", "banked")]
    if failed:
        raise SystemExit(f"not done: {', '.join(failed)} (logs in {root / 'logs'})")


if __name__ == "__main__":
    run_main(main)
