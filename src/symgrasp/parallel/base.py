"""What an executor maps (`Job`), what it yields for a task that raised (`Failure`), the
streaming loop every backend shares (`Executor.map`, `bounded`), and the versions a task's
bytes depend on (`versions`: recorded in a dataset, checked on a cluster's nodes)."""

from __future__ import annotations

import platform
import traceback
import zlib
from abc import ABC, abstractmethod
from collections.abc import Callable, Hashable, Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from importlib.metadata import version
from typing import Any

import symgrasp

PACKAGES = ("numpy", "scipy", "torch", "mujoco", "trimesh")
"""The packages besides symgrasp that compute a task's result (a scene, a database, a
declutter round)."""


def versions() -> dict[str, str]:
    """The versions that decide a task's bytes: Python, zlib (it compresses the scene files),
    symgrasp (its own ``__version__``, so that a checkout run from ``src/`` needs no installed
    metadata) and `PACKAGES`."""
    return {
        "python": platform.python_version(),
        "zlib": zlib.ZLIB_RUNTIME_VERSION,
        "symgrasp": symgrasp.__version__,
        **{name: version(name) for name in PACKAGES},
    }


@contextmanager
def torch_threads(threads: int) -> Iterator[None]:
    """Torch's intra-op threads set to ``threads`` meanwhile, then restored: a task's floats
    then do not depend on the machine's cores, and a task run in the caller's process (the
    in-process executor) leaves the caller's threads as they were. torch is imported here, on
    use: the package imports no torch."""
    import torch

    before = torch.get_num_threads()
    torch.set_num_threads(threads)
    try:
        yield
    finally:
        torch.set_num_threads(before)


@dataclass(frozen=True)
class Job:
    """A pure task mapped over arguments. ``task`` and ``setup`` are module-level functions, or
    ``functools.partial`` of one (a worker imports them by name); ``setup(*setup_args)`` runs
    once in each worker process before its first task, to build what every task reads (a model,
    grasp databases)."""

    task: Callable[[Any], Any]
    setup: Callable[..., None] | None = None
    setup_args: tuple[Any, ...] = ()


@dataclass(frozen=True)
class Failure:
    """In place of a result: the task raised (deterministically, so it is not run again), or
    its worker died more often than the backend retries."""

    error: str
    """The exception's type and message, one line."""
    traceback: str
    """Where it was raised, as Python prints it."""


class TasksFailed(RuntimeError):
    """Some tasks of a job failed; the others' results are kept (the message says where)."""


def attempt(task: Callable[[Any], Any], arg: Any) -> Any:
    """``task(arg)``, or a `Failure` if it raises."""
    try:
        return task(arg)
    except Exception as error:  # a failed task is data: the job goes on
        return Failure(f"{type(error).__name__}: {error}", traceback.format_exc())


def bounded(
    args: Iterable[Any],
    submit: Callable[[Any], Hashable],
    wait: Callable[[list[Hashable]], Iterable[Hashable]],
    limit: int,
) -> Iterator[tuple[Any, Hashable]]:
    """Submit ``args`` one by one (``submit(arg)`` → a handle), keeping at most ``limit`` in
    flight, and yield ``(arg, handle)`` for each handle ``wait(pending)`` reports finished: a
    million tasks never sit in memory at once."""
    queue = iter(args)
    pending: dict[Hashable, Any] = {}
    for arg in queue:
        pending[submit(arg)] = arg
        if len(pending) >= limit:
            break
    while pending:
        for handle in wait(list(pending)):
            yield pending.pop(handle), handle
            for arg in queue:  # one finished, one more in
                pending[submit(arg)] = arg
                break


class Executor(ABC):
    """Runs jobs on ``workers`` workers; a context manager (`close` releases them)."""

    workers: int
    """Tasks run at once."""
    in_process: bool = False
    """Whether tasks run in the calling process (its threads are theirs)."""

    def map(self, job: Job, args: Iterable[Any], desc: str) -> Iterator[tuple[Any, Any]]:
        """``(arg, task(arg) or Failure)`` for every argument, as tasks finish (in argument
        order in process), with a progress bar named ``desc``."""
        from tqdm import tqdm

        args = list(args)
        with tqdm(total=len(args), desc=desc, unit="task", smoothing=0.1) as bar:
            for arg, result in self._results(job, args):
                bar.update()
                yield arg, result

    @abstractmethod
    def _results(self, job: Job, args: list[Any]) -> Iterator[tuple[Any, Any]]:
        """The backend's part of `map`: the pairs, without the progress bar."""

    def close(self) -> None:  # noqa: B027 (a hook: only a backend that started workers stops them)
        """Release the workers."""

    def __enter__(self) -> Executor:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()
