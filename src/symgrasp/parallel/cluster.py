"""Tasks on a Ray cluster (``--backend ray``; the optional extra ``cluster``, imported here
only).

Each task is a Ray task of one CPU. A task whose worker process dies (killed, out of memory,
its node lost) is run again by Ray, up to `MAX_RETRIES` times; a task that raises is not: its
`Failure` is its result. Results come back to the driver as they finish; nothing is written on
the workers' disks, so the cluster's nodes need symgrasp and its inputs (the object sets, a
checkpoint that is not a shipped model) but no shared file system for the outputs.
"""

from __future__ import annotations

import logging
import os
import socket
import uuid
from collections.abc import Iterator
from importlib.metadata import version
from typing import Any

from symgrasp.parallel.base import Executor, Failure, Job, attempt, bounded, versions

MAX_RETRIES = 3
"""Runs of a task after the first whose worker process died."""

CONNECT_TIMEOUT_S = 5.0
"""Seconds to wait for a cluster's head to answer before calling its address unreachable."""

_setup_done: str | None = None
"""In a worker process: the job whose setup has run there."""


def import_ray() -> Any:
    """The ``ray`` module; a ModuleNotFoundError naming the extra to install when it is missing."""
    try:
        import ray
    except ModuleNotFoundError:
        raise ModuleNotFoundError(
            "backend 'ray' (--backend ray) needs Ray, the optional extra 'cluster': "
            "pip install 'symgrasp[cluster]'"
        ) from None
    return ray


def _run(job_id: str, task: Any, setup: Any, setup_args: list[Any], arg: Any) -> Any:
    """The Ray task: a job's ``setup`` once per worker process and job, then ``task(arg)``.
    ``setup_args`` holds a reference to the setup's arguments, put in Ray's object store once
    per job (inside a list, so Ray does not fetch it for every task)."""
    global _setup_done
    if _setup_done != job_id:
        if setup is not None:
            import ray

            setup(*ray.get(setup_args[0]))
        _setup_done = job_id
    return attempt(task, arg)


def node_versions() -> dict[str, str]:
    """`versions` and Ray's: what a node must share with the driver."""
    return {**versions(), "ray": version("ray")}


def _check_reachable(address: str) -> None:
    """Raise ValueError unless something answers at ``address`` = host:port within
    `CONNECT_TIMEOUT_S` (Ray itself waits for minutes)."""
    host, _, port = address.rpartition(":")
    if not host or not port.isdigit():
        raise ValueError(
            f"ray_address must be host:port of a Ray cluster's head (as `ray start --head` "
            f"prints it) or 'auto', got {address!r}"
        )
    try:
        socket.create_connection((host, int(port)), timeout=CONNECT_TIMEOUT_S).close()
    except OSError as error:
        raise ValueError(
            f"ray_address {address}: no Ray cluster answers there ({error.strerror or error}); "
            "start one with `ray start --head` or correct --ray-address / RAY_ADDRESS"
        ) from None


def _one_line(error: BaseException) -> str:
    return " ".join(str(error).split())


class RayCluster(Executor):
    """Tasks on the Ray cluster at ``address`` (default ``$RAY_ADDRESS``), or on a local Ray
    instance of ``workers`` CPUs (default: this machine's) started here and stopped by
    `close`; a process already connected to Ray (``ray.init`` called) keeps its connection.
    ``workers`` tasks are in flight at once (default: the cluster's CPUs).

    Raises:
        ModuleNotFoundError: Ray is not installed.
        ValueError: the address is malformed or nothing answers there, Ray refuses to join
            (its version or Python's differs), or the workers run other versions of what
            computes a task (`versions`) than this process.
    """

    def __init__(self, workers: int | None = None, address: str | None = None) -> None:
        ray = import_ray()
        address = address or os.environ.get("RAY_ADDRESS") or None
        self._started = False
        if not ray.is_initialized():
            if address is not None and address != "auto":
                _check_reachable(address)
            try:
                if address is None:
                    ray.init(num_cpus=workers or os.cpu_count(), include_dashboard=False,
                             log_to_driver=False, logging_level=logging.WARNING)  # fmt: skip
                else:
                    ray.init(address=address, log_to_driver=False, logging_level=logging.WARNING)
            except (ConnectionError, RuntimeError) as error:  # Ray's version check: RuntimeError
                ray.shutdown()
                raise ValueError(f"ray_address {address}: {_one_line(error)}") from None
            self._started = True
        self._ray = ray
        try:
            self._check_versions(address or "a local Ray instance")
        except ValueError:
            self.close()
            raise
        self.workers = workers or max(1, int(ray.cluster_resources().get("CPU", 1)))
        self._task = ray.remote(num_cpus=1, max_retries=MAX_RETRIES)(_run)

    def _check_versions(self, where: str) -> None:
        """Raise ValueError if a node's workers run other `node_versions` than this process."""
        from ray.util.scheduling_strategies import NodeAffinitySchedulingStrategy

        ray = self._ray
        probe = ray.remote(num_cpus=0)(node_versions)
        nodes = [n for n in ray.nodes() if n["Alive"]]
        found = ray.get(
            [
                probe.options(
                    scheduling_strategy=NodeAffinitySchedulingStrategy(n["NodeID"], soft=False)
                ).remote()
                for n in nodes
            ]
        )
        ours = node_versions()
        for node, theirs in zip(nodes, found, strict=True):
            differ = [f"{k} {theirs.get(k)} there, {v} here" for k, v in ours.items()
                      if theirs.get(k) != v]  # fmt: skip
            if differ:
                raise ValueError(
                    f"ray_address {where}: node {node['NodeManagerAddress']} runs other versions "
                    f"than this driver ({'; '.join(differ)}); install the same on every node"
                )

    def _results(self, job: Job, args: list[Any]) -> Iterator[tuple[Any, Any]]:
        ray = self._ray
        job_id, setup_args = uuid.uuid4().hex, [ray.put(job.setup_args)]

        def submit(arg: Any) -> Any:
            return self._task.remote(job_id, job.task, job.setup, setup_args, arg)

        def finished(refs: list[Any]) -> list[Any]:
            return ray.wait(refs, num_returns=1)[0]

        for arg, ref in bounded(args, submit, finished, self.workers):
            try:
                result = ray.get(ref)
            except ray.exceptions.RayError as error:  # its worker died MAX_RETRIES + 1 times
                result = Failure(f"{type(error).__name__}: {_one_line(error)[:300]}", str(error))
            yield arg, result

    def close(self) -> None:
        if self._started:
            self._ray.shutdown()
            self._started = False
