"""Throughput of the rotation representations: loss + backward and decode, on CPU.

    python benchmarks/rotation.py [--batch 65536] [--threads 1] [--repeats 7] [--quick [DIR]]

For every representation and K ∈ {1, 8} ground-truth rotations per element, times
``loss(pred, R_gt, mask).sum().backward()`` on a batch of B float32 elements, and ``decode``
on the same batch; reports elements per second (best of the repeats) and writes
``benchmarks/results/rotation.json``. Target: ``bingham2d`` loss + backward at most 3× the
cost of ``rotmat6d`` at B = 65 536. ``--quick`` times each call once on a small batch.
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

import lab  # noqa: F401  (puts the checkout's root on sys.path, for experiments.scripts)
import torch

from experiments.scripts import (
    best_seconds,
    command_line,
    from_checkout,
    machine,
    parse_args,
    run_main,
)
from symgrasp import rotation
from symgrasp.bingham import eigh3, log_normalizer, triu_to_sym

RESULTS = Path(__file__).parent / "results" / "rotation.json"


def _random_rotations(shape: tuple[int, ...], generator: torch.Generator) -> torch.Tensor:
    q = torch.randn(*shape, 4, generator=generator)
    return rotation.quaternion_to_matrix(q / q.norm(dim=-1, keepdim=True))


def bench(batch: int, repeats: int) -> dict[str, dict[str, float]]:
    generator = torch.Generator().manual_seed(0)
    results: dict[str, dict[str, float]] = {}
    for name in rotation.NAMES:
        representation = rotation.get(name)
        pred = torch.randn(batch, representation.channels, generator=generator)
        row = {}
        for k in (1, 8):
            if k == 1:
                targets, mask = _random_rotations((batch,), generator), None
            else:
                targets = _random_rotations((batch, k), generator)
                mask = torch.rand(batch, k, generator=generator) < 0.75
            leaf = pred.clone().requires_grad_(True)

            def step(leaf=leaf, targets=targets, mask=mask, representation=representation):
                leaf.grad = None
                representation.loss(leaf, targets, mask).sum().backward()

            row[f"loss_backward_k{k}"] = batch / best_seconds(step, repeats)
        with torch.no_grad():
            row["decode"] = batch / best_seconds(
                lambda r=representation, p=pred: r.decode(p), repeats
            )
        results[name] = row
        print(f"  {name:15s} " + "  ".join(f"{key} {value:12,.0f}/s" for key, value in row.items()))
    return results


def bingham2d_breakdown(batch: int, repeats: int) -> dict[str, float]:
    """Seconds per batch of the Bingham-core calls inside the ``bingham2d`` loss: the closed-form
    eigendecomposition and log C with its gradient (``nll`` runs each once)."""
    generator = torch.Generator().manual_seed(1)
    A = triu_to_sym(torch.randn(batch, 6, generator=generator))
    eigenvalues = eigh3(A)[0]

    def normalizer_step() -> None:
        leaf = eigenvalues.clone().requires_grad_(True)
        log_normalizer(leaf).sum().backward()

    return {
        "eigh3": best_seconds(lambda: eigh3(A), repeats),
        "log_normalizer_forward_backward": best_seconds(normalizer_step, repeats),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--batch", type=int, default=65_536, help="rotations per timed call (default: 65 536)"
    )
    parser.add_argument(
        "--threads",
        type=int,
        nargs="+",
        default=[1],
        help="torch CPU thread counts to time, one run each (default: 1)",
    )
    parser.add_argument(
        "--repeats", type=int, default=7, help="timed repeats, the fastest kept (default: 7)"
    )
    parser.add_argument(
        "--output", type=Path, default=RESULTS, help=f"where to write the JSON (default: {RESULTS})"
    )
    args = parse_args(parser, outputs=("output",), quick={"batch": 1024, "repeats": 1})

    runs = []
    for threads in args.threads:
        torch.set_num_threads(threads)
        print(f"threads = {threads}, B = {args.batch} (elements per second, float32)")
        results = bench(args.batch, args.repeats)
        ratios = {
            f"k{k}": results["rotmat6d"][f"loss_backward_k{k}"]
            / results["bingham2d"][f"loss_backward_k{k}"]
            for k in (1, 8)
        }
        print(
            "  bingham2d / rotmat6d loss+backward cost: "
            + ", ".join(f"{key} {value:.1f}×" for key, value in ratios.items())
        )
        breakdown = bingham2d_breakdown(args.batch, args.repeats)
        total = args.batch / results["bingham2d"]["loss_backward_k1"]
        print(
            f"  bingham2d K=1 loss+backward {total * 1e3:.0f} ms per batch, of which Bingham core: "
            + ", ".join(f"{key} {value * 1e3:.0f} ms" for key, value in breakdown.items())
        )
        runs.append(
            {
                "threads": threads,
                "elements_per_second": results,
                "bingham2d_over_rotmat6d_cost": ratios,
                "bingham2d_k1_seconds_per_batch": total,
                "bingham2d_core_seconds_per_batch": breakdown,
            }
        )

    report = {
        "benchmark": "rotation representations: loss + backward and decode throughput",
        "command": command_line(""),
        "environment": {
            key: from_checkout(value)
            for key, value in os.environ.items()
            if key.startswith(("MALLOC_", "OMP_", "MKL_")) or key == "PYTHONPATH"
        },
        "machine": machine(),
        "batch": args.batch,
        "dtype": "float32",
        "repeats": args.repeats,
        "statistic": "best of repeats (the machine is shared)",
        "runs": runs,
    }
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps(report, indent=2) + "\n")
    print(f"wrote {args.output}")


if __name__ == "__main__":
    run_main(main)
