"""Data-parallel training over processes (`torch.distributed`, DistributedDataParallel).

``torchrun --nproc-per-node N -m symgrasp train …`` or ``symgrasp train --nproc N`` (`launch`)
runs N ranks of the one training loop (`symgrasp.model.train`). ``batch_size`` stays the
global batch: every rank draws the same seeded shuffle of the epoch and takes its disjoint
slice of each global batch (`ShardedBatches`), and each rank's loss is weighted by its share of
the batch's labelled voxels (`pooled_voxels`), so the averaged gradient is the one process's
gradient of the whole batch and the run is the same, up to float rounding, for any N.
"""

from __future__ import annotations

import math
import os
import socket
import warnings
from collections.abc import Callable, Iterator
from typing import Any

import torch
import torch.distributed as dist
from torch.nn.parallel import DistributedDataParallel
from torch.utils.data import Sampler

from symgrasp.config import check_global_batch


def start(device: torch.device) -> tuple[int, int, torch.device]:
    """Join the process group torchrun's environment describes (``RANK``, ``WORLD_SIZE``,
    ``MASTER_ADDR``/``PORT``; gloo on CPU, NCCL on GPU); returns (rank, world size, this
    rank's device: ``cuda:LOCAL_RANK`` for CUDA). Alone (no ``WORLD_SIZE``): (0, 1, device)."""
    world = int(os.environ.get("WORLD_SIZE", "1"))
    if world == 1:
        return 0, 1, device
    if device.type == "cuda" and device.index is None:
        local, gpus = int(os.environ.get("LOCAL_RANK", "0")), torch.cuda.device_count()
        if local >= gpus:
            raise ValueError(
                f"{os.environ.get('LOCAL_WORLD_SIZE', local + 1)} training processes on this "
                f"machine need a GPU each, it has {gpus}: pass --nproc {gpus} or less, or "
                "--device cpu"
            )
        device = torch.device("cuda", local)
        torch.cuda.set_device(device)
    if not dist.is_initialized():
        dist.init_process_group("nccl" if device.type == "cuda" else "gloo")
    return dist.get_rank(), world, device


def is_main_process() -> bool:
    """Whether this process speaks for the run: rank 0 of torchrun's ranks (``RANK``), or the
    process alone. Every rank runs the whole command, so only this one prints its outcome."""
    return os.environ.get("RANK", "0") == "0"


def stop() -> None:
    """Leave the process group, once every rank is done (a no-op alone)."""
    if dist.is_initialized():
        dist.barrier()
        dist.destroy_process_group()


def data_parallel(net: torch.nn.Module) -> DistributedDataParallel:
    """``net`` wrapped so that its backward averages the ranks' gradients."""
    # A channels-last 1×1×1 kernel and its gradient differ in the strides of size-1 dimensions
    # only: DDP copies those few gradients into its buckets and would warn on every backward.
    warnings.filterwarnings("ignore", message="Grad strides do not match bucket view strides")
    return DistributedDataParallel(net)


class ShardedBatches(Sampler[list[int]]):
    """Rank ``rank``'s slice of every global batch of ``batch_size`` indices of a shuffle of
    ``range(size)`` drawn from ``generator`` (the same on every rank): the ranks' slices are
    disjoint and together the global batch. A short last batch is padded with its own first
    indices so that every rank takes the same number; alone, exactly the batches of a
    ``RandomSampler`` with ``generator``."""

    def __init__(
        self, size: int, batch_size: int, generator: torch.Generator, rank: int, world: int
    ) -> None:
        check_global_batch(batch_size, world)
        self.size, self.batch_size, self.generator = size, batch_size, generator
        self.rank, self.world = rank, world

    def __iter__(self) -> Iterator[list[int]]:
        order = torch.randperm(self.size, generator=self.generator).tolist()
        for start in range(0, self.size, self.batch_size):
            batch = order[start : start + self.batch_size]
            per_rank = math.ceil(len(batch) / self.world)
            batch = (batch * self.world)[: per_rank * self.world]
            yield batch[self.rank * per_rank : (self.rank + 1) * per_rank]

    def __len__(self) -> int:
        return math.ceil(self.size / self.batch_size)


def pooled_voxels(voxels: int, device: torch.device) -> int:
    """The labelled voxels of the whole global batch: ``voxels`` (this rank's) summed over all
    ranks (``voxels`` alone). The losses are means over a batch's labelled voxels (the validity
    sum divided by their number), so weighting the loss of each part of the batch (a rank's
    slice, a chunk of it) by max(n, 1) / max(N, 1) for its n and this N makes the weighted sum
    the loss of the whole batch."""
    if not dist.is_initialized():
        return voxels
    total = torch.tensor([voxels], dtype=torch.float64, device=device)
    dist.all_reduce(total)
    return round(total.item())


def sum_over_ranks(values: dict[str, float], device: torch.device) -> dict[str, float]:
    """``values`` summed over all ranks (as they are alone)."""
    if not dist.is_initialized():
        return values
    stacked = torch.tensor(list(values.values()), dtype=torch.float64, device=device)
    dist.all_reduce(stacked)
    return dict(zip(values, stacked.tolist(), strict=True))


def launch(function: Callable[..., Any], args: tuple[Any, ...], processes: int) -> None:
    """Run ``function(*args)`` in ``processes`` ranks on this machine, as torchrun would: each
    rank gets torchrun's environment and an equal share of the CPU's threads. Raises the
    ValueError a rank raised (bad input), else torch's error naming the failed rank."""
    from torch.multiprocessing import ProcessRaisedException, spawn

    with socket.socket() as free:  # a port for the ranks' rendezvous
        free.bind(("127.0.0.1", 0))
        port = free.getsockname()[1]
    try:
        spawn(_rank, (processes, port, function, args), nprocs=processes)
    except ProcessRaisedException as error:
        last = str(error).strip().splitlines()[-1]
        if last.startswith("ValueError: "):
            raise ValueError(last.removeprefix("ValueError: ")) from None
        raise


def _rank(rank: int, world: int, port: int, function: Callable[..., Any], args: tuple) -> None:
    os.environ.update(
        MASTER_ADDR="127.0.0.1", MASTER_PORT=str(port), RANK=str(rank), LOCAL_RANK=str(rank),
        WORLD_SIZE=str(world), LOCAL_WORLD_SIZE=str(world),
    )  # fmt: skip
    torch.set_num_threads(max(1, (os.cpu_count() or 1) // world))
    function(*args)
