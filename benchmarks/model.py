"""Cost of the grasp detection network per representation, and the reference run's metrics.

    python benchmarks/model.py [--threads 2] [--repeats 5] [--batch 4] [--data DIR]
        [--run runs/NAME] [--quick [DIR]]

For every rotation representation: trainable parameters, forward FLOPs per 40³ volume
(`symgrasp.model.count_flops`), forward latency at batch 1 on the CPU (eval mode, no grad) and
training throughput on the CPU (scenes per second of forward + loss + backward + Adam step on
a batch of synthetic scenes, `symgrasp.model.synthetic`). With ``--run``, the last epoch of that
training run's ``metrics.csv`` and its command are added. Writes ``benchmarks/results/model.json``.

Where the time of a training step goes: each representation's step is also timed stage by
stage (forward, the validity, score and rotation losses, backward, Adam), median of the
repeats; with ``--data``, loading and augmenting a batch of that dataset folder's training
split (`symgrasp.data.dataset.GraspDataset`, as `symgrasp train` does with ``--workers 0``)
and a whole step on those real batches are timed too, and the first chunk size's step again
with the network's 1×1×1 layers as PyTorch's own `nn.Conv3d` instead of `PointwiseConv3d` (the
same weights, the two taking turns), which tells whether that layer still pays on this machine
and torch. ``--quick`` times each call once on one scene, with one thread.
"""

from __future__ import annotations

import argparse
import copy
import csv
import json
import os
import statistics
import time
from pathlib import Path

import lab  # noqa: F401  (puts the checkout's root on sys.path, for experiments.scripts)
import torch
import torch.nn.functional as F
from torch import nn

from experiments.scripts import best_seconds, command_line, machine, parse_args, run_main
from symgrasp import rotation
from symgrasp.model import (
    GraspNet,
    NetworkConfig,
    TrainConfig,
    count_flops,
    count_parameters,
    grasp_losses,
)
from symgrasp.model.checkpoint import load_checkpoint
from symgrasp.model.loss import at_voxels
from symgrasp.model.network import PointwiseConv3d
from symgrasp.model.synthetic import SyntheticGraspDataset, collate_scenes
from symgrasp.model.train import accumulate_gradient, collate_chunks

RESULTS = Path(__file__).parent / "results" / "model.json"


def bench(name: str, batch: dict[str, torch.Tensor], repeats: int) -> dict[str, float]:
    torch.manual_seed(0)
    model = GraspNet(NetworkConfig(name))
    optimizer = torch.optim.Adam(model.parameters(), lr=1e-4)
    volume = batch["tsdf"][:1]

    @torch.no_grad()
    def forward() -> None:
        model(volume)

    def train_step() -> None:
        losses = grasp_losses(model(batch["tsdf"]), batch, model.representation)
        optimizer.zero_grad(set_to_none=True)
        losses["total"].backward()
        optimizer.step()

    model.eval()
    forward_seconds = best_seconds(forward, repeats)
    model.train()
    step_seconds = best_seconds(train_step, repeats)
    return {
        "parameters": count_parameters(model),
        "forward_gflop": count_flops(model) / 1e9,
        "forward_ms_batch1": forward_seconds * 1e3,
        "train_step_ms": step_seconds * 1e3,
        "train_scenes_per_second": len(batch["tsdf"]) / step_seconds,
    }


def stages(name: str, batch: dict[str, torch.Tensor], repeats: int) -> dict[str, float]:
    """Median milliseconds of each stage of a training step on ``batch``."""
    torch.manual_seed(0)
    model = GraspNet(NetworkConfig(name)).train()
    optimizer = torch.optim.Adam(model.parameters(), lr=1e-4)
    index = batch["voxel_index"]
    times: dict[str, list[float]] = {}
    for repeat in range(repeats + 1):  # the first is a warm-up
        clock = [time.perf_counter()]

        def lap(stage: str, clock: list[float] = clock, repeat: int = repeat) -> None:
            clock.append(time.perf_counter())
            if repeat:
                times.setdefault(stage, []).append(1e3 * (clock[-1] - clock[-2]))

        output = model(batch["tsdf"])
        lap("forward")
        validity = F.binary_cross_entropy_with_logits(
            output.validity, batch["valid"], reduction="sum"
        ) / len(index)
        lap("loss_validity")
        score = (at_voxels(output.score, index) - at_voxels(batch["score"], index)).square().mean()
        lap("loss_score")
        pred = at_voxels(output.rotation, index)
        rotation_loss = model.representation.loss(
            pred, batch["rotations"], batch["rotation_mask"]
        ).mean()
        lap("loss_rotation")
        optimizer.zero_grad(set_to_none=True)
        (validity + score + rotation_loss).backward()
        lap("backward")
        optimizer.step()
        lap("optimizer")
    return {stage: statistics.median(values) for stage, values in times.items()}


def real_batches(
    data: Path, batch: int, micro_batches: list[int], repeats: int
) -> dict[str, object]:
    """Loading + augmenting ``batch`` scenes of ``data``'s training split, and a whole
    ``bingham2d`` step on them (`symgrasp.model.train`'s: collated in chunks of each of
    ``micro_batches`` scenes, forward and backward per chunk, Adam), the chunk sizes taking
    turns on the same scenes: medians over ``repeats`` batches [ms]."""
    from symgrasp.data.dataset import GraspDataset, collate_scenes

    dataset = GraspDataset(data, split="train", augment=True, seed=0)
    model = GraspNet(NetworkConfig("bingham2d")).train()
    plain = _pointwise_as_conv3d(copy.deepcopy(model))
    optimizers = {m: torch.optim.Adam(m.parameters(), lr=1e-4) for m in (model, plain)}
    config = TrainConfig(data=str(data), out="unused", lr=1e-4)
    load, voxels = [], []
    step: dict[int, list[float]] = {size: [] for size in micro_batches}
    plain_step: list[float] = []

    def timed(net: GraspNet, size: int, items: list[dict[str, torch.Tensor]]) -> float:
        begin = time.perf_counter()
        optimizers[net].zero_grad(set_to_none=True)
        accumulate_gradient(net, net, collate_chunks(collate_scenes, size, items), config, 1, 1)
        optimizers[net].step()
        return 1e3 * (time.perf_counter() - begin)

    for repeat in range(repeats + 1):
        start = time.perf_counter()
        items = [dataset[(repeat * batch + i) % len(dataset)] for i in range(batch)]
        scenes = collate_scenes(items)
        loaded = time.perf_counter()
        if repeat % 2:
            plain_ms = timed(plain, micro_batches[0], items)
        times = {size: timed(model, size, items) for size in micro_batches}
        if not repeat % 2:
            plain_ms = timed(plain, micro_batches[0], items)
        if repeat:  # the first is a warm-up
            for size, ms in times.items():
                step[size].append(ms)
            plain_step.append(plain_ms)
            load.append(1e3 * (loaded - start))
            voxels.append(len(scenes["voxel_index"]))
    return {
        "dataset": str(data),
        "load_and_augment_ms": statistics.median(load),
        "bingham2d_step_ms": statistics.median(step[micro_batches[0]]),
        "bingham2d_step_ms_by_micro_batch": {
            size: statistics.median(t) for size, t in step.items()
        },
        "bingham2d_step_ms_pointwise_as_conv3d": statistics.median(plain_step),
        "pointwise_speed_up_per_batch": [
            p / s for p, s in zip(plain_step, step[micro_batches[0]], strict=True)
        ],
        "valid_voxels_per_batch": statistics.median(voxels),
    }


def _pointwise_as_conv3d(net: GraspNet) -> GraspNet:
    """``net`` with each `PointwiseConv3d` replaced by an `nn.Conv3d` holding its parameters."""
    for module in list(net.modules()):
        for name, child in list(module.named_children()):
            if isinstance(child, PointwiseConv3d):
                conv = nn.Conv3d(child.in_channels, child.out_channels, 1)
                conv.weight, conv.bias = child.weight, child.bias
                setattr(module, name, conv)
    return net


def reference_run(run: Path) -> dict[str, object]:
    """The last epoch of a training run folder and the command that reproduces it."""
    with open(run / "metrics.csv") as file:
        rows = list(csv.DictReader(file))
    config = load_checkpoint(run / "last.pt")["config"]
    command = (
        f"symgrasp train --data {config['data']} --rep {config['representation']} "
        f"--gripper {config['gripper']} --out {config['out']} --epochs {config['epochs']} "
        f"--batch-size {config['batch_size']} --lr {config['lr']} --seed {config['seed']}"
    )
    return {"run": str(run), "command": command, "last_epoch": rows[-1], "epochs": len(rows)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--threads", type=int, default=2, help="torch CPU threads (default: 2)")
    parser.add_argument("--repeats", type=int, default=5, help="timed repeats (default: 5)")
    parser.add_argument(
        "--batch", type=int, default=4, help="scenes per training step (default: 4)"
    )
    parser.add_argument(
        "--data", type=Path, help="a dataset folder: time loading its batches and steps on them"
    )
    parser.add_argument(
        "--micro-batch", type=int, nargs="+", metavar="M",
        help="with --data: scenes per forward/backward pass of a step on real batches "
        "(symgrasp train --micro-batch; 0 = the whole batch), each timed in turn on the same "
        "scenes (default: 0 and every other divisor of --batch)",
    )  # fmt: skip
    parser.add_argument("--run", type=Path, help="a finished training run folder to tabulate")
    parser.add_argument("--output", type=Path, default=RESULTS, help="where to write the JSON")
    args = parse_args(parser, outputs=("output",), quick={"threads": 1, "repeats": 1, "batch": 1})

    torch.set_num_threads(args.threads)
    micro = args.micro_batch or [0, *(m for m in range(1, args.batch) if args.batch % m == 0)]
    dataset = SyntheticGraspDataset(args.batch, seed=0)
    batch = collate_scenes([dataset[i] for i in range(args.batch)])
    results = {}
    for name in rotation.NAMES:
        results[name] = bench(name, batch, args.repeats)
        print(f"  {name:15s} " + "  ".join(f"{k} {v:,.4g}" for k, v in results[name].items()))
        results[name]["train_step_stages_ms"] = stages(name, batch, args.repeats)
        print(
            " " * 18
            + "  ".join(f"{k} {v:.3g}" for k, v in results[name]["train_step_stages_ms"].items())
        )
    report = {
        "benchmark": "grasp detection network: size, CPU latency and training throughput",
        "command": command_line(""),
        "machine": machine(),
        "batch": args.batch,
        "valid_voxels_in_batch": len(batch["voxel_index"]),
        "repeats": args.repeats,
        "statistic": "best of repeats after a warm-up (the machine is shared)",
        "representations": results,
        "real_batches": real_batches(args.data, args.batch, micro, args.repeats)
        if args.data
        else None,
        "reference_run": reference_run(args.run) if args.run else None,
    }
    args.output.parent.mkdir(parents=True, exist_ok=True)
    temporary = args.output.with_suffix(".tmp")
    temporary.write_text(json.dumps(report, indent=2) + "\n")
    os.replace(temporary, args.output)
    print(f"wrote {args.output}")


if __name__ == "__main__":
    run_main(main)
