"""Mapping pure, seed-keyed tasks over workers: in this process, a pool of local processes, or
a Ray cluster, behind one interface.

A job (`Job`) is a module-level task function of one argument (a seed, a scene id) with an
optional per-worker setup; an executor (`open_executor`) runs it over the arguments and
yields ``(argument, result)`` pairs as they finish, a `Failure` in place of the result of a
task that raised. Results travel back to the caller, which writes them (atomically, on its
own disk): what a job makes does not depend on the backend or the number of workers.
This package imports neither torch nor Ray; Ray loads only when the backend ``ray`` is asked
for.
"""

from symgrasp.config import ParallelConfig
from symgrasp.parallel.base import Executor, Failure, Job, TasksFailed, torch_threads


def open_executor(parallel: ParallelConfig) -> Executor:
    """The executor ``parallel`` asks for, ready to `Executor.map` (use it as a context manager:
    closing it stops the local Ray instance it started). Connecting to a Ray cluster happens
    here, so a caller opens the executor before it writes anything.

    Raises:
        ModuleNotFoundError: backend "ray" without Ray installed.
        ValueError: a Ray cluster that cannot be joined or runs other versions than this
            process (`symgrasp.parallel.cluster.RayCluster`).
    """
    if parallel.backend == "ray":
        from symgrasp.parallel.cluster import RayCluster

        return RayCluster(parallel.workers, parallel.ray_address)
    from symgrasp.parallel.local import InProcess, ProcessPool

    return ProcessPool(parallel.workers) if (parallel.workers or 1) > 1 else InProcess()


__all__ = [
    "Executor",
    "Failure",
    "Job",
    "ParallelConfig",
    "TasksFailed",
    "open_executor",
    "torch_threads",
]
