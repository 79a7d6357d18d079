"""Run a plan of long commands (datasets, training runs, benchmarks) that outlives any session.

    PYTHONPATH=src python experiments/campaign.py run PLAN.toml [PLAN.toml ...] [--root DIR] [--cores 2] [--bank DIR] [--first NAME ...]
    PYTHONPATH=src python experiments/campaign.py status PLAN.toml [PLAN.toml ...] [--root DIR] [--bank DIR]
    PYTHONPATH=src python experiments/campaign.py show PLAN.toml [PLAN.toml ...] [--root DIR]
    PYTHONPATH=src python experiments/campaign.py pack --bank DIR [--split-mb 20]
    PYTHONPATH=src python experiments/campaign.py unpack --bank DIR [--out out/bank]
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
that finishes leaves its record in ``DIR/index.json`` (its command, ``{root}`` in place of the
root, its plan file's name, and the SHA-256 of each file its ``keep`` patterns match under the
root, with where the bank holds it) and those files in an archive of its own,
``DIR/step-NAME.tar.xz``::

    [[step]]
    name = "select-s0"
    needs = ["train-s0"]
    run = "symgrasp select {runs}/s0 ..."
    keep = ["runs/s0/best.pt", "runs/s0/selection.json", "bench/s0/**", "!bench/s0/**/*.log"]

A pattern is a path relative to the root (or under ``{root}``) whose ``*`` and ``?`` stay within
one folder and whose ``**`` spans folders; one that starts with ``!`` leaves out what it
matches. A step finishes only when each of its patterns matches a file. The bank stores no file
twice: a kept file that ``--copies`` already hold byte for byte (by default the stored rounds,
``experiments/results/*.tar.gz``, and the shipped models) is named in the index by that copy
(a path relative to ``DIR``, and the member of a tar archive), and a checkpoint (``*.pt``)
held nowhere else is not committed at all, the index keeping its SHA-256 (a rerun prints
whether it made the same bytes). An archive is deterministic: sorted members, no times, owners
or modes of the machine, xz at a fixed preset, so the same files make the same bytes.
``pack`` merges a bank's archives into one per plan file (``DIR/plan-PLAN.tar.xz``, split into
``plan-PLAN-N.tar.xz`` above ``--split-mb``), leaving out what the copies hold by then: run it
once, when a campaign ends (each pack adds its archives to the history again). ``unpack``
writes every banked file, checked, to ``--out/STEP/…``, for a reader of a finished campaign.

On a root without a step's done marker, ``run`` restores a banked step whose command is
unchanged and whose archives and copies still have their recorded hashes (its files back in the
root, each archive read once, the marker written) and does not run it. A banked step that keeps
nothing (a dataset too large to commit) or whose checkpoint was left out counts as done while
nothing still to run needs it; when a step to run does, it runs again (its command's own resume
and fixed seeds make the same outputs): so a plan should keep, on the steps that end a chain,
whatever a later step or the report reads.
"""

from __future__ import annotations

import argparse
import datetime
import fnmatch
import functools
import glob
import hashlib
import io
import json
import os
import re
import shlex
import subprocess
import sys
import tarfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from scripts import ROOT as REPOSITORY
from scripts import command_line, parse_args, run_main, write_result

from symgrasp.arguments import number
from symgrasp.atomic import read_json, write_atomic
from symgrasp.digest import file_sha256

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

POLL_SECONDS = 1.0
INDEX = "index.json"
"""A bank's index: each step's record and where each of its kept files is."""
ARCHIVE = ".tar.xz"
XZ_PRESET = 9
SPLIT_MB = 20.0
"""`pack` splits a plan's archive into parts above this size (MB), by default."""
CHECKPOINT = ".pt"
"""The suffix of the files a bank leaves out unless a copy holds them (the module docstring)."""
COPIES = ("experiments/results/*.tar.gz", "src/symgrasp/detect/models/*.pt")
"""Where the repository holds copies of kept files (relative to it): the stored rounds and the
shipped models."""


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


def _stamp(path: Path) -> tuple[int, int]:
    """What tells a file's later versions apart for the caches below: its size and mtime."""
    stat = path.stat()
    return stat.st_size, stat.st_mtime_ns


@functools.cache
def _file_hash(path: Path, stamp: tuple[int, int]) -> str:
    return file_sha256(path)


@functools.cache
def _member_hashes(path: Path, stamp: tuple[int, int]) -> dict[str, str]:
    """The SHA-256 of each file in the tar archive ``path`` (member name → hex)."""
    with tarfile.open(path) as archive:
        return {member.name: hashlib.sha256(archive.extractfile(member).read()).hexdigest()
                for member in archive if member.isfile()}  # fmt: skip


def _is_tar(path: Path) -> bool:
    return path.name.endswith((".tar", ".tar.gz", ".tgz", ".tar.xz"))


def copies_in(patterns: list[str], base: Path) -> list[Path]:
    """The files the glob ``patterns`` (relative to ``base``, or absolute) match, sorted: the
    places a bank looks for its files' copies (`catalogue`)."""
    return sorted({Path(path).resolve() for pattern in patterns
                   for path in glob.glob(os.path.join(base, pattern)) if os.path.isfile(path)})  # fmt: skip


def catalogue(copies: list[Path], bank: Path) -> dict[str, dict[str, str]]:
    """Where ``copies`` hold each content: SHA-256 → an index entry's place, ``in`` (the path
    relative to ``bank``) and, in a tar archive, ``member``; the first place in sorted order."""
    places: dict[str, dict[str, str]] = {}
    for path in sorted(copies):
        where = os.path.relpath(path, bank)
        if _is_tar(path):
            for member, digest in sorted(_member_hashes(path, _stamp(path)).items()):
                places.setdefault(digest, {"in": where, "member": member})
        else:
            places.setdefault(_file_hash(path, _stamp(path)), {"in": where})
    return places


def read_index(bank: Path) -> dict[str, Any]:
    """The bank's index (`deposit`), or an empty one where the bank has none.

    Raises:
        SystemExit: the index is not JSON or lacks ``archives`` or ``steps`` (one line naming it).
    """
    path = bank / INDEX
    if not path.is_file():
        return {"archives": {}, "steps": {}}
    try:
        return read_json(path, "campaign bank index", dict, ("archives", "steps"))
    except ValueError as error:
        raise SystemExit(f"error: {error}") from None


def _write_index(bank: Path, index: dict[str, Any]) -> None:
    """Write ``index`` and delete the bank's archives it no longer refers to."""
    used = {entry["in"] for record in index["steps"].values()
            for entry in record["files"].values() if entry.get("in") in index["archives"]}  # fmt: skip
    index["archives"] = {name: index["archives"][name] for name in sorted(used)}
    text = json.dumps(index, indent=1, sort_keys=True) + "\n"
    write_atomic(bank / INDEX, lambda file: file.write(text), "w")
    for archive in bank.glob("*" + ARCHIVE):
        if archive.name not in used:
            archive.unlink()


def _write_archive(path: Path, members: dict[str, bytes]) -> str:
    """``members`` (name → bytes) as a tar.xz at ``path``, sorted, with fixed times, owners and
    modes: the same members make the same bytes. Its SHA-256."""

    def write(file: Any) -> None:
        with tarfile.open(fileobj=file, mode="w:xz", preset=XZ_PRESET,
                          format=tarfile.PAX_FORMAT) as archive:  # fmt: skip
            for name in sorted(members):
                info = tarfile.TarInfo(name)  # mtime 0, owner 0, mode 0o644
                info.size = len(members[name])
                archive.addfile(info, io.BytesIO(members[name]))

    write_atomic(path, write)
    return file_sha256(path)


def _read_members(path: Path, wanted: dict[str, str]) -> dict[str, bytes]:
    """The bytes of the members of the tar archive ``path`` that ``wanted`` names (member →
    SHA-256), in one pass.

    Raises:
        SystemExit: one is missing or not the file ``wanted`` names.
    """
    found = {}
    with tarfile.open(path) as archive:
        for member in archive:
            if member.isfile() and member.name in wanted:
                found[member.name] = archive.extractfile(member).read()
    for name, digest in wanted.items():
        if name not in found or hashlib.sha256(found[name]).hexdigest() != digest:
            raise SystemExit(f"error: bank: {os.path.normpath(path)} lacks {name} or holds "
                             "another file; the bank's index names it with its SHA-256")  # fmt: skip
    return found


def _place(digest: str, name: str, places: dict[str, dict[str, str]]) -> dict[str, str] | None:
    """Where the bank keeps a file of ``name`` and SHA-256 ``digest`` instead of in its own
    archive: a copy's place, ``{}`` for a checkpoint without one (left out), or None (stored)."""
    if digest in places:
        return places[digest]
    return {} if name.endswith(CHECKPOINT) else None


def deposit(step: Step, root: Path, bank: Path, copies: list[Path] = ()) -> None:
    """Bank ``step``: its record in the bank's index and its kept files in its own archive
    (`ARCHIVE`, named after it), but for those ``copies`` already hold and checkpoints, which
    the index names by their SHA-256 alone; replaces any earlier record of the step. Where the
    earlier record left a checkpoint out, says whether the new one has its bytes."""
    files = kept_files(step, root)  # before anything changes: a pattern may match nothing
    index, places = read_index(bank), catalogue(list(copies), bank)
    earlier = index["steps"].get(step.name, {}).get("files", {})
    archive = f"step-{step.name}{ARCHIVE}"
    entries, stored = {}, {}
    for name in files:
        data = (root / name).read_bytes()
        digest = hashlib.sha256(data).hexdigest()
        place = _place(digest, name, places)
        if place is None:
            stored[f"{step.name}/{name}"] = data
            place = {"in": archive}
        entries[name] = {"sha256": digest, **place}
        if name in earlier and "in" not in earlier[name]:
            same = earlier[name]["sha256"] == digest
            print(f"bank: {step.name}'s {name} is {'the' if same else 'not the'} checkpoint its "
                  f"earlier record names ({earlier[name]['sha256'][:12]})", flush=True)  # fmt: skip
    if stored:
        index["archives"][archive] = _write_archive(bank / archive, stored)
    index["steps"][step.name] = {"run": _rooted(step, root), "plan": step.plan.stem,
                                 "banked": _now().isoformat(), "files": entries}  # fmt: skip
    _write_index(bank, index)


def pack(bank: Path, copies: list[Path], split_mb: float = SPLIT_MB) -> dict[str, int]:
    """Rewrite the bank's archives as one per plan (``plan-PLAN.tar.xz``; parts
    ``plan-PLAN-N.tar.xz`` where one would pass ``split_mb`` MB), leaving out the files that
    ``copies`` now hold; each archive's size in bytes. What a finished campaign commits: the
    step archives of its sessions merged, the same members giving the same bytes."""
    index = read_index(bank)
    stored: dict[str, dict[str, bytes]] = {}  # plan → member → bytes
    for archive, digest in index["archives"].items():
        if _file_hash(bank / archive, _stamp(bank / archive)) != digest:
            raise SystemExit(f"error: bank: {bank / archive} is not the archive its index names")
        wanted = {f"{name}/{file}": entry["sha256"] for name, record in index["steps"].items()
                  for file, entry in record["files"].items() if entry.get("in") == archive}  # fmt: skip
        for member, data in _read_members(bank / archive, wanted).items():
            plan = index["steps"][member.split("/", 1)[0]]["plan"]
            stored.setdefault(plan, {})[member] = data
    return _repack(bank, index, stored, catalogue(copies, bank), int(split_mb * 1e6))


def _repack(bank: Path, index: dict[str, Any], stored: dict[str, dict[str, bytes]],
            places: dict[str, dict[str, str]], limit: int) -> dict[str, int]:  # fmt: skip
    """`pack` of ``stored`` (plan → member → bytes) into ``index``'s steps, ``places`` where
    copies are, ``limit`` bytes an archive."""
    sizes = {}
    for plan, members in sorted(stored.items()):
        for member in list(members):
            step, name = member.split("/", 1)
            entry = index["steps"][step]["files"][name]
            place = places.get(entry["sha256"])
            if place is not None:
                index["steps"][step]["files"][name] = {"sha256": entry["sha256"], **place}
                del members[member]
        if not members:
            continue
        size = sum(map(len, members.values()))  # bytes before compression, of a part
        while True:
            groups = _split(members, size)
            names = ([f"plan-{plan}{ARCHIVE}"] if len(groups) == 1 else
                     [f"plan-{plan}-{n}{ARCHIVE}" for n in range(1, len(groups) + 1)])  # fmt: skip
            written = {name: bank / f".{name}.pack" for name in names}  # renamed when all fit
            digests = {name: _write_archive(written[name], group)
                       for name, group in zip(names, groups, strict=True)}  # fmt: skip
            largest = max(path.stat().st_size for path in written.values())
            if largest <= limit or len(groups) == len(members):
                break
            for path in written.values():
                path.unlink()
            size = int(size * 0.9 * limit / largest)
        for name, group in zip(names, groups, strict=True):
            sizes[name] = written[name].stat().st_size
            os.replace(written[name], bank / name)
            index["archives"][name] = digests[name]
            for member in group:
                step, file = member.split("/", 1)
                index["steps"][step]["files"][file]["in"] = name
    _write_index(bank, index)
    return sizes


def _split(members: dict[str, bytes], size: int) -> list[dict[str, bytes]]:
    """``members`` in runs of sorted names, each of ``size`` bytes at most or of one member."""
    groups: list[dict[str, bytes]] = [{}]
    filled = 0
    for name in sorted(members):
        if groups[-1] and filled + len(members[name]) > size:
            groups.append({})
            filled = 0
        groups[-1][name] = members[name]
        filled += len(members[name])
    return groups


def _rooted(step: Step, root: Path) -> str:
    """``step``'s command as the bank records it: ``{root}`` for the root, which another
    machine may place elsewhere."""
    return step.run.replace(str(root), "{root}")


def banked(step: Step, root: Path, bank: Path | None) -> dict[str, dict[str, str]] | None:
    """The kept files of ``step``'s record in ``bank`` (name → index entry: ``sha256`` and where
    its bytes are, no ``in`` for a checkpoint left out), or None where there is none for its
    command, or an archive or copy holding one is missing or not what the index names."""
    index = None if bank is None else read_index(bank)
    record = None if index is None else index["steps"].get(step.name)
    if record is None or record["run"] != _rooted(step, root):
        return None
    for entry in record["files"].values():
        if "in" in entry and not _holds(bank, index["archives"], entry):
            print(f"bank: {os.path.normpath(bank / entry['in'])} is missing or not the file its "
                  f"index names; {step.name} is not restored", flush=True)  # fmt: skip
            return None
    return record["files"]


def _holds(bank: Path, archives: dict[str, str], entry: dict[str, str]) -> bool:
    """Whether the place an index ``entry`` names holds its file: the bank's archive with the
    index's SHA-256, or a copy (a file, or a tar archive's member) of the entry's."""
    source = bank / entry["in"]
    if not source.is_file():
        return False
    if entry["in"] in archives:
        return _file_hash(source, _stamp(source)) == archives[entry["in"]]
    if "member" in entry:
        return _member_hashes(source, _stamp(source)).get(entry["member"]) == entry["sha256"]
    return _file_hash(source, _stamp(source)) == entry["sha256"]


def restorable(files: dict[str, dict[str, str]]) -> bool:
    """Whether a banked step's files are all in the bank or its copies (no checkpoint left out)."""
    return all("in" in entry for entry in files.values())


def extract(steps: dict[str, dict[str, dict[str, str]]], bank: Path,
            target: Callable[[str, str], Path]) -> None:  # fmt: skip
    """Write the banked files of ``steps`` (step → `banked`'s entries) to ``target(step, name)``,
    each archive read once, each file's SHA-256 checked; a target already holding the file is
    left as it is; checkpoints left out are skipped."""
    archives = read_index(bank)["archives"]
    wanted: dict[Path, dict[str, tuple[str, list[Path]]]] = {}  # source → member → (sha, targets)
    for step, files in steps.items():
        for name, entry in files.items():
            path = target(step, name)
            if "in" not in entry or (path.is_file() and file_sha256(path) == entry["sha256"]):
                continue
            source = bank / entry["in"]
            member = f"{step}/{name}" if entry["in"] in archives else entry.get("member", "")
            wanted.setdefault(source, {}).setdefault(member, (entry["sha256"], []))[1].append(path)
    for source, members in sorted(wanted.items()):
        if not _is_tar(source):  # a plain file, a copy
            ((digest, _),) = members.values()
            found = {"": source.read_bytes()}
            if hashlib.sha256(found[""]).hexdigest() != digest:
                raise SystemExit(f"error: bank: {os.path.normpath(source)} is not the file the "
                                 "bank's index names")  # fmt: skip
        else:
            found = _read_members(source, {m: digest for m, (digest, _) in members.items()})
        for member, (_, paths) in members.items():
            for path in paths:
                write_atomic(path, lambda file, data=found[member]: file.write(data))


def withdraw(steps: list[tuple[Step, dict[str, dict[str, str]]]], root: Path, bank: Path) -> None:
    """Put the banked files of ``steps`` (each with `banked`'s entries, all `restorable`) back
    under ``root`` and mark them done."""
    for step, files in steps:
        for name in files:
            if name.startswith("/") or ".." in name.split("/"):
                raise SystemExit(f"error: bank {bank / INDEX}: {step.name} keeps {name!r}, "
                                 "which is not a path under the root")  # fmt: skip
    extract({step.name: files for step, files in steps}, bank, lambda _, name: root / name)
    for step, _ in steps:
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


def run(steps: list[Step], root: Path, cores: int, bank: Path | None = None,
        copies: list[Path] = ()) -> dict[str, str]:  # fmt: skip
    """Run the plan's missing steps (see the module docstring), banking each that finishes in
    ``bank`` (``copies``: `deposit`); each step's outcome."""
    for name, (pid, identity, started) in _running(root).items():
        if _alive(pid, identity):
            raise SystemExit(f"error: step {name!r} is still running (process {pid}, started "
                             f"{started}): another campaign.py runs on {root}; stop it first")  # fmt: skip
        (root / "running" / name).unlink()  # its driver was killed: the step resumes below
    resting, restored = set(), []
    for step in steps:
        files = None if is_done(step, root) else banked(step, root, bank)
        if files is not None and step.keep and restorable(files):
            restored.append((step, files))
        elif files is not None:
            resting.add(step.name)
    if restored:
        withdraw(restored, root, bank)
        for step, _ in restored:
            print(f"{step.name}: restored from {bank}", flush=True)
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
            kept = process.returncode == 0 and _deposit_or_why(step, root, bank, copies)
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


def _deposit_or_why(step: Step, root: Path, bank: Path | None, copies: list[Path]) -> bool | str:
    """Bank a step that exited 0: True, or why it could not (a keep pattern matched nothing)."""
    if bank is None:
        return True
    try:
        deposit(step, root, bank, copies)
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
        elif (files := banked(step, root, bank)) is not None:
            states[step.name] = (
                "banked: the next run restores it" if step.keep and restorable(files) else
                f"banked{' without its checkpoints' * bool(step.keep)}: runs again only if a "
                "step to run needs it"
            )  # fmt: skip
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
    parser.add_argument("action", nargs="?", default="run",
                        choices=("run", "status", "show", "pack", "unpack"),
                        help="run the plan (default), list its steps' state, show its steps as "
                        "JSON lines, their vars filled in; pack the --bank's archives into one per "
                        "plan, or unpack its files into --out (neither takes a plan)")  # fmt: skip
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
                        "step's record and the files its 'keep' patterns match, compressed; a "
                        "root without them takes them back from it (default: no bank)")  # fmt: skip
    parser.add_argument("--copies", nargs="+", default=list(COPIES), metavar="GLOB",
                        help="files whose contents the bank does not store again, naming where "
                        "they are (tar archives: their members; relative to the repository; "
                        f"default: {' '.join(COPIES)})")  # fmt: skip
    parser.add_argument("--split-mb", type=number(1e-6, 1e6), default=SPLIT_MB,
                        help="pack: a plan's archive larger than this many MB is split into "
                        f"parts (default: {SPLIT_MB:g})")  # fmt: skip
    parser.add_argument("--out", type=Path, default=Path("out/bank"),
                        help="unpack: the folder each banked step's files are written to, in a "
                        "folder named after the step (default: out/bank)")  # fmt: skip
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
    bank = None if args.bank is None else args.bank.resolve()
    copies = copies_in(args.copies, REPOSITORY)
    if args.action in ("pack", "unpack"):
        if bank is None or args.plan:
            parser.error(f"{args.action} takes --bank DIR and no plan")
        if not (bank / INDEX).is_file():
            parser.error(f"--bank: {bank} holds no {INDEX}, so it is not a campaign's bank")
        if args.action == "pack":
            for name, size in pack(bank, copies, args.split_mb).items():
                print(f"{bank / name}: {size / 1e6:.1f} MB")
            return
        records = read_index(bank)["steps"]
        extract({name: record["files"] for name, record in records.items()}, bank,
                lambda step, name: args.out / step / name)  # fmt: skip
        for name, record in records.items():
            for file, entry in record["files"].items():
                if "in" not in entry:
                    print(f"{name}: {file} is not banked (a checkpoint, SHA-256 "
                          f"{entry['sha256']}): its step makes it again")  # fmt: skip
        print(f"unpacked {len(records)} steps into {args.out}")
        return
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
    if args.action == "status":
        for name, state in status(steps, root, bank).items():
            print(f"{name:30s} {state}")
        return
    if args.action == "show":
        for step in steps:
            print(json.dumps({"name": step.name, "cores": step.cores, "needs": list(step.needs),
                              "keep": list(step.keep), "run": step.run}))  # fmt: skip
        return
    outcome = run(steps, root, args.cores, bank, copies)
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
