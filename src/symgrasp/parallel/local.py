"""Tasks in this process, or in a pool of local processes (the default backend, no extra
dependency). A pool worker that dies ends the job with ``BrokenProcessPool``; what finished is
on disk and ``--resume`` runs the rest."""

from __future__ import annotations

import multiprocessing
from collections.abc import Iterator
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from typing import Any

from symgrasp.parallel.base import Executor, Job, attempt, bounded


class InProcess(Executor):
    """One worker: this process, tasks in argument order."""

    workers = 1
    in_process = True

    def _results(self, job: Job, args: list[Any]) -> Iterator[tuple[Any, Any]]:
        if job.setup is not None:
            job.setup(*job.setup_args)
        for arg in args:
            yield arg, attempt(job.task, arg)


class ProcessPool(Executor):
    """``workers`` spawned processes, one pool per job (its setup is the pool's initializer)."""

    def __init__(self, workers: int) -> None:
        self.workers = workers

    def _results(self, job: Job, args: list[Any]) -> Iterator[tuple[Any, Any]]:
        # spawn, not fork: a forked child inherits torch's thread pools and can deadlock
        spawn = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(self.workers, spawn, initializer=job.setup,
                                 initargs=job.setup_args) as pool:  # fmt: skip

            def submit(arg: Any) -> Future:
                return pool.submit(attempt, job.task, arg)

            def finished(futures: list[Future]) -> set[Future]:
                return wait(futures, return_when=FIRST_COMPLETED).done

            for arg, future in bounded(args, submit, finished, 2 * self.workers):
                yield arg, future.result()
