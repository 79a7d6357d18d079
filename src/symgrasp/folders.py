"""Output folders, one rule for every command that writes one, and the names that become file
names.

A command's output folder is

- *named*: a path that is not empty or blank (``''`` would write into the current folder,
  ``' '`` into a folder called by a space) and is not a file, nor under one (`check_folder`);
- *its own*: it holds only what the command writes (`Outputs`), unless it holds the command's
  record, its own earlier output, which the command then checks itself (``--resume``, a
  configuration that must match); a folder of someone else's files is refused, not written
  into (`check_owned`). Hidden entries are not looked at: the lock, a killed write's
  temporary file, a file manager's;
- *written by one process at a time*: `output_folder` holds an advisory exclusive lock,
  ``fcntl.flock`` on the file `LOCK` inside the folder, for the whole run, and a second writer
  is refused at once with one line naming the folder and the process holding it. Only the
  process that runs the command takes the lock; the workers it starts (``--workers``, Ray,
  data loaders) do not. The kernel releases a flock when its process ends, however it ends
  (an exception, a crash, SIGKILL), so the lock file a killed run leaves behind holds nothing
  and the next run (``--resume``) takes it; a run that ends removes it.

flock is POSIX (Linux, macOS); Windows is not a target. On a network file system the lock is
as good as its server's locking (NFSv4: between clients too).

Names from user data (a URDF's robot name, a mesh file's stem) that the package puts into file
names are checked by `check_file_name`.
"""

from __future__ import annotations

import fcntl
import fnmatch
import functools
import inspect
import os
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar, cast

LOCK = ".symgrasp.lock"
"""The lock file of an output folder: empty but for the process id of its holder."""


def check_path(path: str | Path, name: str | None = "out") -> Path:
    """``path`` as a Path; a ValueError naming ``name`` when it is empty or blank (``''``
    would mean the current folder, ``' '`` a folder called by a space)."""
    if not str(path).strip():
        raise ValueError(f"{name + ' ' if name else ''}must name a path, got {str(path)!r}")
    return Path(path)


def check_folder(path: str | Path, name: str = "out") -> Path:
    """``path`` as a folder that can be made or written into, checked before any work: a
    ValueError naming ``name`` when it is empty or blank (`check_path`) or when it, or a
    folder above it, is a file."""
    path = check_path(path, name)
    for above in (path, *path.parents):
        if above.exists() and not above.is_dir():
            where = "is" if above == path else f"would be under {above}, which is"
            raise ValueError(f"{name} {path} {where} a file, not a folder")
    return path


@dataclass(frozen=True)
class Outputs:
    """What a command writes into its output folder, for `check_owned`."""

    what: str
    """What the folder is, in the refusal's words ("a symgrasp dataset")."""
    kinds: tuple[str, ...] = ()
    """The entries a folder without the record may hold (`fnmatch` patterns of their names):
    what the command leaves before its record is written, and caches it reuses; none where
    the record comes first."""
    record: tuple[str, ...] = ()
    """The entries that mark the command's own earlier output: a folder holding one of them
    is the command's to check (resume or refuse), whatever else it holds."""

    def foreign(self, folder: Path) -> list[str]:
        """The names of ``folder``'s entries this command did not write, sorted; none when
        ``folder`` is missing or holds the record."""
        if not folder.is_dir() or any((folder / name).exists() for name in self.record):
            return []
        return sorted(
            entry.name
            for entry in folder.iterdir()
            if not entry.name.startswith(".")
            and not any(fnmatch.fnmatchcase(entry.name, kind) for kind in self.kinds)
        )


PICTURES = Outputs("pictures and their records", kinds=("*.png", "*.json", "*.md", "*.html"))
"""A folder of pictures (``sim show``, ``demo``, ``detect``, ``figures``): the pictures, the
numbers and commands behind them, pages showing them; docs/figures is one."""


def check_owned(folder: str | Path, outputs: Outputs, name: str = "out") -> None:
    """A ValueError naming ``name`` when ``folder`` holds entries that ``outputs`` does not
    account for (`Outputs.foreign`)."""
    foreign = outputs.foreign(Path(folder))
    if foreign:
        listed = ", ".join(foreign[:3]) + (", …" if len(foreign) > 3 else "")
        raise ValueError(
            f"{name} {folder} holds files that are not {outputs.what} ({listed}); choose an "
            "empty or new folder"
        )


@contextmanager
def output_folder(path: str | Path, outputs: Outputs | None, name: str = "out") -> Iterator[Path]:
    """Hold the folder ``path`` for one run: checked (`check_folder`, and `check_owned` with
    ``outputs``, None for a folder that the command checks itself), made if missing, and
    locked (module doc) until the block ends. A ValueError naming ``name`` when another
    process holds it, or this one already does (the lock is not re-entrant). At the end the lock file is removed, and so are the folders made here
    if nothing was written into them (a refused run leaves nothing behind)."""
    folder = check_folder(path, name)
    if outputs is not None:
        check_owned(folder, outputs, name)
    made = [f for f in (folder, *folder.parents) if not f.exists()]
    lock = None
    try:
        lock = _acquire(folder, name)
        yield folder
    finally:
        if lock is not None:
            _release(folder / LOCK, lock)
        for empty in made:
            try:
                empty.rmdir()
            except OSError:  # written into (or made by another run meanwhile): kept
                break


def _acquire(folder: Path, name: str) -> int:
    """The descriptor of ``folder``'s lock file, locked by this process (made, with the
    folder, if missing)."""
    path = folder / LOCK
    while True:
        folder.mkdir(parents=True, exist_ok=True)
        try:
            lock = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        except FileNotFoundError:  # the folder was removed by a run that left it empty
            continue
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.read(lock, 32).decode(errors="replace").strip()
            os.close(lock)
            by = f"process {holder}" if holder.isdigit() else "another process"
            raise ValueError(
                f"{name} {folder} is being written by {by} (one writer per folder, "
                f"{LOCK}); wait for it to finish or choose another folder"
            ) from None
        try:  # the file its last holder removed before letting go is not the lock: again
            same = os.path.samestat(os.fstat(lock), os.stat(path))
        except FileNotFoundError:
            same = False
        if same:
            os.ftruncate(lock, 0)
            os.write(lock, f"{os.getpid()}\n".encode())
            return lock
        os.close(lock)


def _release(path: Path, lock: int) -> None:
    """Remove the lock file ``path`` while still holding it through ``lock``, so that a later
    writer opens a new file rather than this one, then let go."""
    try:
        if os.path.samestat(os.fstat(lock), os.stat(path)):
            os.unlink(path)
    except FileNotFoundError:  # the folder was removed during the run
        pass
    os.close(lock)


F = TypeVar("F", bound=Callable[..., Any])


def writes_folder(outputs: Outputs | None, parameter: str = "out") -> Callable[[F], F]:
    """Decorate a function that writes the folder its argument ``parameter`` names: each call
    runs inside `output_folder` of that folder (errors name ``parameter``)."""

    def decorate(function: F) -> F:
        signature = inspect.signature(function)

        @functools.wraps(function)
        def held(*args: Any, **kwargs: Any) -> Any:
            bound = signature.bind(*args, **kwargs)
            bound.apply_defaults()
            with output_folder(bound.arguments[parameter], outputs, parameter):
                return function(*args, **kwargs)

        return cast(F, held)

    return decorate


def check_file_name(name: str, what: str = "name") -> str:
    """``name`` when it can be one file or folder name; a ValueError naming ``what`` when it
    is empty, holds a path separator (``/`` or ``\\``) or a control character, or is ``.`` or
    ``..``. For names read from user data that the package puts into file names (an object's,
    in its grasp database's cache file): refused rather than changed, since two names changed
    alike would share one file. A gripper's name follows the stricter
    `symgrasp.sim.grippers.NAME_PATTERN`, being typed on command lines too."""
    bad = (
        not isinstance(name, str)
        or name in ("", ".", "..")
        or any(c in "/\\" or ord(c) < 32 or ord(c) == 127 for c in name)
    )
    if bad:
        raise ValueError(
            f"{what} must be one file name (not empty, '.' or '..', no '/', '\\' or control "
            f"character), got {name!r}"
        )
    return name
