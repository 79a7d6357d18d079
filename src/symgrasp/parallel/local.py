"""Tasks in this process, or in a pool of local processes (the default backend, no extra
dependency). A pool worker that dies ends the job with ``BrokenProcessPool``; what finished is
on disk and ``--resume`` runs the rest. The pool's workers die with the process that started
them: `close` (reached as an interrupt unwinds) terminates them at once, and on Linux the
kernel kills them when that process dies without a chance to (SIGKILL)."""

from __future__ import annotations

import ctypes
import multiprocessing
import os
import signal
import sys
from collections.abc import Callable, Iterator
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from contextlib import contextmanager
from typing import Any

from symgrasp.parallel.base import Executor, Job, attempt, bounded

_PR_SET_PDEATHSIG = 1
"""prctl(2)'s option: the signal this process gets when its parent dies."""


class InProcess(Executor):
    """One worker: this process, tasks in argument order."""

    workers = 1
    in_process = True

    def _results(self, job: Job, args: list[Any]) -> Iterator[tuple[Any, Any]]:
        if job.setup is not None:
            job.setup(*job.setup_args)
        for arg in args:
            yield arg, attempt(job.task, arg)


def _start_worker(parent: int, setup: Callable[..., None] | None, setup_args: tuple) -> None:
    """A pool worker's initializer: tie its life to ``parent`` (pid), then ``setup``.

    Ctrl-C reaches the whole process group; the parent stops the workers, so they ignore it
    (one interrupted in its setup would break the pool, and the parent might then report a
    dead worker instead of the interrupt). Until here SIGINT stayed blocked, as the parent
    spawned the worker (`_spawning`): a Ctrl-C while it imported is dropped, not a traceback.
    PR_SET_PDEATHSIG is the kernel's guarantee that the worker gets SIGKILL when the parent
    dies, even by SIGKILL, mid-task; the pid check covers a parent that died before the call."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    if sys.platform == "linux":
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
        if os.getppid() != parent:
            os._exit(1)
    if setup is not None:
        setup(*setup_args)


@contextmanager
def _spawning() -> Iterator[None]:
    """Block SIGINT in this thread meanwhile: a worker started now inherits the mask through
    exec and keeps it until its initializer ignores SIGINT, so a Ctrl-C while it is still
    importing is not a KeyboardInterrupt of its own. This process's Ctrl-C waits (pending) for
    the end of the block, or another thread takes it; none is lost."""
    blocked = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, blocked)


class ProcessPool(Executor):
    """``workers`` spawned processes, one pool per job (its setup is the pool's initializer)."""

    def __init__(self, workers: int) -> None:
        self.workers = workers
        self._pool: ProcessPoolExecutor | None = None
        """The pool of the job being mapped, until it finishes."""

    def _results(self, job: Job, args: list[Any]) -> Iterator[tuple[Any, Any]]:
        # spawn, not fork: a forked child inherits torch's thread pools and can deadlock
        spawn = multiprocessing.get_context("spawn")
        initargs = (os.getpid(), job.setup, job.setup_args)
        with ProcessPoolExecutor(self.workers, spawn, initializer=_start_worker,
                                 initargs=initargs) as pool:  # fmt: skip
            self._pool = pool

            def submit(arg: Any) -> Future:
                with _spawning():  # a submit may start a worker
                    return pool.submit(attempt, job.task, arg)

            def finished(futures: list[Future]) -> set[Future]:
                return wait(futures, return_when=FIRST_COMPLETED).done

            try:
                for arg, future in bounded(args, submit, finished, 2 * self.workers):
                    yield arg, future.result()
            except BaseException:  # an interrupt: the tasks in flight are not waited for
                self.close()
                raise
        self._pool = None

    def close(self) -> None:
        """Terminate the workers of a job that did not finish (an interrupt, a failure in the
        caller) instead of waiting for their tasks."""
        pool, self._pool = self._pool, None
        if pool is None:
            return
        for process in list((pool._processes or {}).values()):  # public in Python 3.14 only
            process.terminate()
        pool.shutdown(wait=True, cancel_futures=True)
