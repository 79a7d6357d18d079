"""Training of the grasp detector: one readable loop, configured by a plain dataclass.

``train(TrainConfig(...))`` reads ``symgrasp.data.dataset.GraspDataset`` (train and val splits
of ``config.data``; ``train_scenes``, ``val_scenes``: the first N of a split), trains `GraspNet` with Adam
(AdamW with ``weight_decay``) on `grasp_losses`, the lr of each step from
`symgrasp.model.schedule`, each batch passed in chunks of ``micro_batch`` scenes whose
gradients add up to the batch's (`accumulate_gradient`), validates after every epoch and
writes into ``config.out``:

- ``last.pt`` after every epoch, ``best.pt`` at the lowest validation loss (`checkpoint`) and,
  with ``keep_every`` N, ``epoch_NNN.pt`` every N epochs;
- ``metrics.csv``: one row per epoch, training losses and validation losses and metrics, and
  ``lr``, the learning rate of the epoch's last step;
- ``learning_curve.png``: the same as plots.

With ``ema`` on, an exponential moving average of the weights (`symgrasp.model.averaging`) is
what is validated and what the checkpoints' ``model`` holds (what `load_model` loads); the
trained weights themselves are kept as ``model_raw`` so that a run resumes exactly.

Same seed, same result: the weights are initialised from ``config.seed``, epoch e shuffles with
a generator seeded from (seed, e) and selects the dataset's augmentation draws of epoch e
(``set_epoch``), so a run resumed from ``last.pt`` (``resume=True``) continues exactly as if it
had not stopped. CUDA is used when available (``device="auto"``),
with bfloat16 autocast for the network only (``autocast``; off, float32 as on the CPU); the
losses run in float32 (float64 inside the Bingham normaliser).

The same loop runs data-parallel when started by torchrun or ``symgrasp train --nproc N``
(`symgrasp.model.distributed`): ``batch_size`` is the global batch, each rank trains on its
slice of it, and the run is the one-process run up to float rounding. Rank 0 alone validates
(on the whole val split, so validity AP, a ranking over every voxel, is exactly the one
process's) and writes the checkpoints and metrics; ``metrics.csv`` and the checkpoints record
the world size, the global batch and the learning rate.
"""

from __future__ import annotations

import contextlib
import functools
import math
import time
from collections.abc import Callable
from dataclasses import asdict
from pathlib import Path
from typing import Any

import torch
from torch.utils.data import DataLoader, Dataset
from tqdm import tqdm

import symgrasp
from symgrasp.atomic import write_atomic, write_csv
from symgrasp.config import LossWeights, TrainConfig, ValidityLoss
from symgrasp.device import resolve_device
from symgrasp.folders import Outputs, output_folder
from symgrasp.model import distributed
from symgrasp.model.averaging import WeightAverage
from symgrasp.model.checkpoint import load_checkpoint, save_checkpoint, trained_gripper
from symgrasp.model.loss import grasp_losses
from symgrasp.model.metrics import MetricAccumulator
from symgrasp.model.network import GraspNet
from symgrasp.model.schedule import learning_rate
from symgrasp.sim.grippers import GripperSpec, get_gripper, same_name_note

Tensor = torch.Tensor
Batch = dict[str, Tensor]
Collate = Callable[[list[dict[str, Tensor]]], Batch]


def open_dataset(config: TrainConfig) -> tuple[Dataset, Dataset, Collate]:
    """The train and val splits of ``config.data`` and their collate function."""
    try:
        from symgrasp.data.dataset import VAL_EVERY, GraspDataset, collate_scenes
    except ImportError as error:
        raise RuntimeError(
            "symgrasp.data is needed to read a dataset folder; it is not installed"
        ) from error

    train_set = GraspDataset(config.data, split="train", augment=config.augment, seed=config.seed)
    val_set = GraspDataset(config.data, split="val", augment=False, seed=config.seed)
    if not len(train_set) or not len(val_set):
        raise ValueError(
            f"dataset {config.data} has {len(train_set)} training and {len(val_set)} validation "
            f"scenes; both are needed (every {VAL_EVERY}th scene id is held out for validation, "
            f"so generate at least {VAL_EVERY} scenes)"
        )
    return train_set, val_set, collate_scenes


class FirstScenes(Dataset):
    """The first ``count`` scenes of ``dataset`` by scene id (its ``scene_ids``, one per item,
    else the item indices), with its ``gripper``, ``manifest`` and ``set_epoch``: an item is
    the dataset's item of that scene, augmented as it would be there."""

    def __init__(self, dataset: Any, count: int, option: str = "train_scenes") -> None:
        ids = list(getattr(dataset, "scene_ids", range(len(dataset))))
        if not 1 <= count <= len(ids):
            raise ValueError(
                f"{option} must be in [1, {len(ids)}], the scenes of the split, got {count}"
            )
        self.dataset = dataset
        self.indices = sorted(range(len(ids)), key=ids.__getitem__)[:count]
        self.scene_ids = [ids[i] for i in self.indices]
        self.gripper, self.manifest = dataset.gripper, dataset.manifest

    def set_epoch(self, epoch: int) -> None:
        if hasattr(self.dataset, "set_epoch"):
            self.dataset.set_epoch(epoch)

    def __len__(self) -> int:
        return len(self.indices)

    def __getitem__(self, i: int) -> dict[str, Tensor]:
        return self.dataset[self.indices[i]]


def check_dataset(dataset: Any, config: TrainConfig, asked: GripperSpec) -> None:
    """Raise ValueError unless ``dataset`` was produced for ``asked``, the spec of
    ``config.gripper``."""
    if dataset.gripper != asked:
        raise ValueError(
            f"dataset {config.data!r} was produced for the gripper {dataset.gripper.name!r}, "
            f"but gripper {config.gripper!r} was asked for{same_name_note(dataset.gripper, asked)}"
        )


TRAINING_RUN = Outputs("a training run", record=("last.pt",))
"""A run folder (`symgrasp.folders`): ``last.pt``, written after every epoch, is its record, so
a folder without one must be empty; `symgrasp select` writes into it too."""


def train(
    config: TrainConfig,
    datasets: tuple[Dataset, Dataset, Collate] | None = None,
) -> list[dict[str, float]]:
    """Train (or resume) the run ``config`` describes; returns the per-epoch history (on rank 0;
    other ranks return what they resumed from).

    ``datasets`` = (train split, val split, collate function) replaces `open_dataset` (tests
    pass the synthetic dataset); each split needs the contract's ``gripper`` and ``manifest``.
    ``config.out`` is held for the call by the process that writes it, rank 0
    (`symgrasp.folders.output_folder`): a folder holding anything but a run, or held by
    another process, is refused (ValueError).
    """
    main = distributed.is_main_process()
    with output_folder(config.out, TRAINING_RUN) if main else contextlib.nullcontext():
        return _train(config, datasets)


def _train(
    config: TrainConfig, datasets: tuple[Dataset, Dataset, Collate] | None
) -> list[dict[str, float]]:
    train_set, val_set, collate = datasets or open_dataset(config)
    if config.train_scenes:
        train_set = FirstScenes(train_set, config.train_scenes)
    if config.val_scenes:
        val_set = FirstScenes(val_set, config.val_scenes, "val_scenes")
    asked = get_gripper(config.gripper)
    for dataset in (train_set, val_set):
        check_dataset(dataset, config, asked)
    rank, world, device = distributed.start(resolve_device(config.device))
    generator = torch.Generator()  # seeded per epoch: the same shuffle on every rank
    batches = distributed.ShardedBatches(len(train_set), config.batch_size, generator, rank, world)
    out = Path(config.out)
    out.mkdir(parents=True, exist_ok=True)

    torch.manual_seed(config.seed)
    if device.type == "cuda":
        torch.backends.cudnn.benchmark = False
        torch.use_deterministic_algorithms(True, warn_only=True)
        # without autocast float32 is meant as on the CPU: no TF32 (10-bit mantissa) convolutions
        torch.backends.cudnn.allow_tf32 = config.autocast
    net = GraspNet(config.network).to(device)
    if config.weight_decay:
        optimizer = torch.optim.AdamW(net.parameters(), config.lr, weight_decay=config.weight_decay)
    else:
        optimizer = torch.optim.Adam(net.parameters(), lr=config.lr)
    average = WeightAverage(net, config.ema) if config.ema else None
    validated = average.module if average else net  # validated, saved as "model"
    history: list[dict[str, float]] = []
    best_val_loss = math.inf
    if config.resume and (out / "last.pt").exists():  # nothing to resume: a fresh start
        state = load_checkpoint(out / "last.pt", config.network.representation, device)
        _check_resume(state, train_set, config)
        if average:
            net.load_state_dict(state["model_raw"])
            average.module.load_state_dict(state["model"])
        else:
            net.load_state_dict(state["model"])
        optimizer.load_state_dict(state["optimizer"])
        history, best_val_loss = state["history"], state["best_val_loss"]
    elif (out / "last.pt").exists():
        raise ValueError(f"out {str(out)!r} already holds a run; resume it or choose another out")
    model = net if world == 1 else distributed.data_parallel(net)

    train_loader = DataLoader(
        train_set,
        batch_sampler=batches,
        collate_fn=functools.partial(collate_chunks, collate, config.micro_batch),
        num_workers=config.workers,
    )
    val_loader = DataLoader(
        val_set, batch_size=config.batch_size, collate_fn=collate, num_workers=config.workers
    )
    bar = tqdm(
        total=config.epochs * len(batches),
        initial=len(history) * len(batches),
        desc="train",
        unit="step",
        dynamic_ncols=True,
        disable=rank > 0,
    )
    for epoch in range(len(history), config.epochs):
        start = time.perf_counter()
        generator.manual_seed(config.seed * 1_000_003 + epoch)
        if hasattr(train_set, "set_epoch"):  # the dataset's augmentation draws of this epoch
            train_set.set_epoch(epoch)
        bar.set_description(f"epoch {epoch + 1}/{config.epochs}")
        train_losses, lr = _train_epoch(
            model, net, optimizer, average, train_loader, epoch, config, world, bar
        )
        if rank > 0:  # validation, checkpoints and metrics are rank 0's
            continue
        val_losses, metrics = evaluate(
            validated, val_loader, config.loss_weights, device, config.validity, config.autocast
        )
        _check_finite(torch.tensor(val_losses["total"]), "validation loss", config)
        row = {
            "epoch": epoch + 1,
            **{f"train_{k}": v for k, v in train_losses.items()},
            **{f"val_{k}": v for k, v in val_losses.items()},
            **metrics,
            "world_size": world,
            "global_batch_size": config.batch_size,
            "lr": lr,
            "seconds": time.perf_counter() - start,
        }
        history.append(row)
        state = {
            "symgrasp_version": symgrasp.__version__,
            "representation": config.network.representation,
            "gripper": train_set.gripper.to_dict(),
            "object_set": train_set.manifest.get("object_set"),
            "dataset_hash": train_set.manifest.get("dataset_hash"),
            "network": asdict(config.network),
            "config": config.record(),
            "epoch": epoch + 1,
            "world_size": world,
            "history": history,
            "best_val_loss": min(best_val_loss, val_losses["total"]),
            "model": validated.state_dict(),
            **({"model_raw": net.state_dict()} if average else {}),
            "optimizer": optimizer.state_dict(),
        }
        save_checkpoint(out / "last.pt", state)
        if config.keep_every and (epoch + 1) % config.keep_every == 0:
            save_checkpoint(out / f"epoch_{epoch + 1:03d}.pt", state)
        if val_losses["total"] < best_val_loss:
            best_val_loss = val_losses["total"]
            save_checkpoint(out / "best.pt", state)
        write_csv(out / "metrics.csv", history)
        plot_learning_curve(out / "learning_curve.png", history)
        bar.write(
            f"epoch {epoch + 1}: train {train_losses['total']:.4f}  val {val_losses['total']:.4f}  "
            + "  ".join(f"{k} {v:.4g}" for k, v in metrics.items())
        )
    bar.close()
    distributed.stop()
    return history


def _check_finite(loss: Tensor, what: str, config: TrainConfig) -> None:
    """Stop a diverged run before a non-finite loss reaches the weights or a checkpoint."""
    if not torch.isfinite(loss):
        kept = Path(config.out) / "last.pt"
        raise ValueError(
            f"training diverged: the {what} is {loss.item()} (lr {config.lr}; try a smaller "
            "--lr); "
            + (f"{kept} holds the last finite epoch" if kept.exists() else "no epoch finished")
        )


def _check_resume(state: dict[str, Any], train_set: Any, config: TrainConfig) -> None:
    trained_for = trained_gripper(state)
    if trained_for != train_set.gripper:
        raise ValueError(
            f"cannot resume: the checkpoint was trained for the gripper {trained_for.name!r}, "
            f"the dataset is for {train_set.gripper.name!r}"
            f"{same_name_note(trained_for, train_set.gripper)}"
        )
    if state["dataset_hash"] != train_set.manifest.get("dataset_hash"):
        raise ValueError(
            f"cannot resume: the checkpoint was trained on dataset {state['dataset_hash']!r}, "
            f"{config.data!r} is {train_set.manifest.get('dataset_hash')!r}"
        )
    if asdict(config.network) != state["network"]:
        raise ValueError(
            f"cannot resume: network {asdict(config.network)} differs from the checkpoint's "
            f"{state['network']}"
        )
    recorded, asked = TrainConfig.from_record(state["config"]).record(), config.record()
    fixed = _RECIPE if _flat(config) else (*_RECIPE, "epochs", "batch_size")
    changed = [name for name in fixed if recorded[name] != asked[name]]
    if changed:
        raise ValueError(
            "cannot resume: the checkpoint's run has "
            + ", ".join(f"{name} {recorded[name]!r}" for name in changed)
            + "; asked for "
            + ", ".join(f"{name} {asked[name]!r}" for name in changed)
            + " (a run keeps its recipe"
            + ("" if _flat(config) else " and the length its lr schedule spans")
            + "; start a new --out to change it)"
        )


_RECIPE = (
    "autocast",
    "lr",
    "schedule",
    "warmup",
    "min_lr",
    "ema",
    "weight_decay",
    "validity_loss",
    "focal_gamma",
    "focal_alpha",
    "ignore_band",
    "train_scenes",
)
"""The fields of `TrainConfig` a resumed run must keep (by their names in its `record`):
changed midway, they would make a run that no straight run reproduces."""


def _flat(config: TrainConfig) -> bool:
    """Whether the lr does not depend on the run's length (more epochs can be added)."""
    return config.schedule == "constant" and config.warmup == 0


def _autocast(device: torch.device, enabled: bool) -> torch.autocast:
    """bfloat16 autocast on CUDA when ``enabled``; a no-op elsewhere."""
    return torch.autocast(
        device_type=device.type, dtype=torch.bfloat16, enabled=enabled and device.type == "cuda"
    )


def _to(batch: dict[str, Tensor], device: torch.device) -> dict[str, Tensor]:
    return {key: value.to(device, non_blocking=True) for key, value in batch.items()}


def _train_epoch(
    model: torch.nn.Module,
    net: GraspNet,
    optimizer: torch.optim.Optimizer,
    average: WeightAverage | None,
    loader: DataLoader,
    epoch: int,
    config: TrainConfig,
    world: int,
    bar: tqdm,
) -> tuple[dict[str, float], float]:
    """Epoch ``epoch`` (0-based): one pass over ``loader`` (this rank's slices of the global
    batches); the mean of each loss over the global batches and the lr of the last step.
    ``model`` is ``net`` or its DistributedDataParallel wrapper."""
    model.train()
    sums: dict[str, float] = {}
    shown = 0.0  # running mean, for the progress bar
    total, lr = config.epochs * len(loader), config.lr
    for step, chunks in enumerate(loader, start=1):
        optimizer.zero_grad(set_to_none=True)
        losses = accumulate_gradient(model, net, chunks, config, world, step)
        lr = learning_rate(config, epoch * len(loader) + step - 1, total)
        for group in optimizer.param_groups:
            group["lr"] = lr
        optimizer.step()
        if average is not None:
            average.update(net)
        for key, value in losses.items():
            sums[key] = sums.get(key, 0.0) + value
        shown += (losses["total"] * world - shown) / step  # data-parallel: about the batch's
        bar.set_postfix(loss=f"{shown:.4f}")
        bar.update()
    sums = distributed.sum_over_ranks(sums, device=next(net.parameters()).device)
    return {key: value / max(len(loader), 1) for key, value in sums.items()}, lr


def collate_chunks(collate: Collate, size: int, items: list[dict[str, Tensor]]) -> list[Batch]:
    """``items`` (this rank's slice of a global batch) collated in chunks of ``size`` scenes
    (0: one chunk)."""
    size = size or len(items)
    return [collate(items[start : start + size]) for start in range(0, len(items), size)]


def accumulate_gradient(
    model: torch.nn.Module,
    net: GraspNet,
    chunks: list[Batch],
    config: TrainConfig,
    world: int,
    step: int,
) -> dict[str, float]:
    """Forward and backward passes over ``chunks`` (this rank's slice of one global batch, in
    chunks of ``config.micro_batch`` scenes), adding to the weights' ``grad`` the gradient of
    the whole global batch's loss; returns this rank's part of each loss (summed over the ranks:
    the batch's loss). Each chunk's losses are means over its n labelled voxels and are weighted
    by max(n, 1) / max(N, 1), N the global batch's (`distributed.pooled_voxels`), so their sum is
    the batch's loss; the network (GroupNorm) treats every scene alone."""
    device = next(net.parameters()).device
    counts = [len(chunk["voxel_index"]) for chunk in chunks]
    pooled = distributed.pooled_voxels(sum(counts), device)
    parts: dict[str, float] = {}
    for i, (chunk, count) in enumerate(zip(chunks, counts, strict=True)):
        chunk = _to(chunk, device)
        share = max(count, 1) / max(pooled, 1)
        # data-parallel: the ranks average their gradients once, after the last chunk
        synced = world == 1 or i == len(chunks) - 1
        with contextlib.nullcontext() if synced else model.no_sync():
            with _autocast(device, config.autocast):
                output = model(chunk["tsdf"])
            losses = grasp_losses(
                output, chunk, net.representation, config.loss_weights, config.validity
            )
            _check_finite(losses["total"], f"training loss at step {step}", config)
            (losses["total"] * (share * world)).backward()  # DDP divides the gradient sum by world
        for key, value in losses.items():
            parts[key] = parts.get(key, 0.0) + value.item() * share
    return parts


@torch.no_grad()
def evaluate(
    model: GraspNet,
    loader: DataLoader,
    weights: LossWeights | None = None,
    device: torch.device | str = "cpu",
    validity_loss: ValidityLoss | None = None,
    autocast: bool = True,
) -> tuple[dict[str, float], dict[str, float]]:
    """Mean losses (per batch; the validity loss ``validity_loss``, default BCE) and
    `MetricAccumulator` metrics of ``model`` on ``loader``, under bfloat16 autocast on CUDA when
    ``autocast`` (as `TrainConfig.autocast` trained it)."""
    device, weights = torch.device(device), weights or LossWeights()
    model.eval()
    accumulator = MetricAccumulator(model.representation)
    sums: dict[str, float] = {}
    for batch in tqdm(loader, desc="validate", unit="batch", leave=False, dynamic_ncols=True):
        batch = _to(batch, device)
        with _autocast(device, autocast):
            output = model(batch["tsdf"])
        losses = grasp_losses(output, batch, model.representation, weights, validity_loss)
        for key, value in losses.items():
            sums[key] = sums.get(key, 0.0) + value.item()
        accumulator.update(output, batch)
    return {k: v / max(len(loader), 1) for k, v in sums.items()}, accumulator.compute()


def plot_learning_curve(path: Path, history: list[dict[str, float]]) -> None:
    """Losses and validation metrics against the epoch, as a PNG written atomically."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    epochs = [row["epoch"] for row in history]
    panels = [
        ("loss", ["train_total", "val_total"]),
        ("validity", ["train_validity", "val_validity"]),
        ("validity AP", ["validity_ap"]),
        ("score MAE at valid voxels", ["score_mae"]),
        ("median rotation error [deg]", ["ex_median_deg", "ez_median_deg"]),
        ("mean confidence", ["confidence_correct", "confidence_wrong"]),
    ]
    figure, axes = plt.subplots(2, 3, figsize=(13, 7), constrained_layout=True)
    for axis, (title, keys) in zip(axes.flat, panels, strict=True):
        for key in keys:
            if key in history[0]:
                axis.plot(epochs, [row[key] for row in history], marker="o", label=key)
        axis.set_title(title)
        axis.set_xlabel("epoch")
        if axis.lines:
            axis.legend(fontsize="small")
    write_atomic(path, lambda file: figure.savefig(file, format="png", dpi=90))
    plt.close(figure)
