"""Run a plan of long commands (datasets, training runs, benchmarks) that outlives any session.

    PYTHONPATH=src python experiments/campaign.py run PLAN.toml [PLAN.toml ...] [--root DIR] [--cores 2]
    PYTHONPATH=src python experiments/campaign.py status PLAN.toml [PLAN.toml ...] [--root DIR]
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
in ``--cores``, and returns when nothing more can start. A step is done when it exited 0 with
the same command: ``ROOT/done/NAME`` holds the command it finished, so an edited command runs
again. Every command must resume its own work (symgrasp's ``--resume``), because a session's
end kills whatever runs: the next ``run`` starts those steps again and they continue where they
stopped. A failed step is recorded in ``ROOT/failed/NAME`` (exit code, time) and run again by the
next ``run``; the steps needing it wait. A running step has ``ROOT/running/NAME`` (its process
id, the boot and tick it started at, its start time): ``status`` tells a running step from one
whose driver was killed (a process id reused after a restart included), and a second ``run``
on the same root while the first still runs a step is refused. Output goes to
``ROOT/logs/NAME.log``. ``show`` prints the steps as ``run`` would start them, their vars filled
in, one JSON object a line (``name``, ``cores``, ``needs``, ``run``). ``--quick`` runs a four-step plan of Python one-liners (one failing)
twice and writes ``campaign.json``.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import shlex
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from symgrasp.scripts import parse_args, run_main, write_result

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
        unknown = set(entry) - {"name", "run", "cores", "needs"}
        if unknown or not {"name", "run"} <= set(entry):
            raise SystemExit(
                f"error: plan {path}: step {entry.get('name', '?')!r} needs 'name' and 'run' "
                f"and may have 'cores', 'needs'; got {sorted(entry)}"
            )
        try:
            run = " ".join(entry["run"].split()).format(**values)
        except KeyError as error:
            raise SystemExit(f"error: plan {path}: step {entry['name']!r} uses {error}, "
                             f"which [vars] does not define") from None  # fmt: skip
        steps.append(Step(entry["name"], run, path, int(entry.get("cores", 1)),
                          tuple(entry.get("needs", ()))))  # fmt: skip
    return steps


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


def run(steps: list[Step], root: Path, cores: int) -> dict[str, str]:
    """Run the plan's missing steps (see the module docstring); each step's outcome."""
    for name, (pid, identity, started) in _running(root).items():
        if _alive(pid, identity):
            raise SystemExit(f"error: step {name!r} is still running (process {pid}, started "
                             f"{started}): another campaign.py runs on {root}; stop it first")  # fmt: skip
        (root / "running" / name).unlink()  # its driver was killed: the step resumes below
    outcome = {step.name: "done" for step in steps if is_done(step, root)}
    running: dict[str, tuple[Step, subprocess.Popen, datetime.datetime]] = {}
    (root / "logs").mkdir(parents=True, exist_ok=True)
    while True:
        for name, (step, process, started) in list(running.items()):
            if process.poll() is None:
                continue
            del running[name]
            now = _now()
            if process.returncode == 0:
                _mark(root / "done", name, step.run)
                (root / "failed" / name).unlink(missing_ok=True)
                outcome[name] = "done"
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


def status(steps: list[Step], root: Path) -> dict[str, str]:
    """Each step's state on disk: done, running, stopped with its driver, failed, or not yet."""
    states, running = {}, _running(root)
    for step in steps:
        failed = root / "failed" / step.name
        if is_done(step, root):
            states[step.name] = "done"
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
    if args.action == "status":
        for name, state in status(steps, root).items():
            print(f"{name:30s} {state}")
        return
    if args.action == "show":
        for step in steps:
            print(json.dumps({"name": step.name, "cores": step.cores, "needs": list(step.needs),
                              "run": step.run}))  # fmt: skip
        return
    outcome = run(steps, root, args.cores)
    if args.quick:  # again: only what failed runs
        again = run(steps, root, args.cores)
        command = " ".join(["python", *sys.argv])
        write_result(args.quick / "campaign", "campaign driver, quick plan", command, [],
                     steps={"first run": outcome, "second run": again})  # fmt: skip
        return
    failed = [name for name, state in status(steps, root).items() if state != "done"]
    if failed:
        raise SystemExit(f"not done: {', '.join(failed)} (logs in {root / 'logs'})")


if __name__ == "__main__":
    run_main(main)
