"""How sharp a Bingham head's mode is where the detector looks → experiments/results/eigen_gap.{json,md}.

    PYTHONPATH=src python experiments/eigen_gap.py --checkpoints A.pt B.pt \\
        [--data DIR] [--scenes 50] [--threshold 0.08] [--quick [DIR]]

The mode of a Bingham density exp(vᵀAv) is A's top eigenvector, and it is well defined only as
far as the largest eigenvalue λ₁ stands above the next, λ₂ (Ko et al. 2024, Eq. 6 and the
confidence of Sec. 3.3). A symmetric hand's grasp has two correct rotations, R and R turned
by π about e_x. ``bingham2d`` models the closing axis e_z, the same line for both, so one
eigenvector can carry it. ``bingham3d`` (on S³) sees two quaternions q and q ⊗ i that are
orthogonal, so a density high on both is high on the whole great circle between them: the
fit drives λ₁ and λ₂ together and the mode anywhere on that circle (every yaw about e_x).
Per checkpoint of a Bingham representation, at every voxel whose validity probability is at
least ``--threshold`` (the voxels the detector considers) in every ``len/scenes``-th scene of
the validation split of ``--data`` (default: the checkpoint's own dataset), no augmentation:
the median gaps λ₁ − λ₂ and λ₂ − λ₃ of A. ``--quick``: the shipped Robotiq model on two
synthetic scenes.
"""

from __future__ import annotations

import argparse
import statistics
from pathlib import Path
from typing import Any

import torch
from common import add_checkpoint_options, add_result_option, per_checkpoint
from scripts import command_line, parse_args, run_main, write_result

from symgrasp.model.checkpoint import load_model


def gaps(checkpoint: str | Path, items: list[dict[str, torch.Tensor]], threshold: float) -> dict:
    """Median eigenvalue gaps of the Bingham parameter A of ``checkpoint`` at the voxels of
    ``items`` (dataset items) whose validity probability is at least ``threshold``."""
    model, _ = load_model(checkpoint)
    representation = model.representation
    if not representation.has_distribution:
        raise ValueError(f"checkpoint {checkpoint} is {representation.name}, not a Bingham head")
    top, second = [], []
    with torch.no_grad():
        for item in items:
            out = model(item["tsdf"].unsqueeze(0))
            kept = torch.sigmoid(out.validity[0]) >= threshold
            pred = out.rotation[0].permute(1, 2, 3, 0)[kept].double()
            eigenvalues = representation.distribution(pred).eigenvalues  # ascending
            top += (eigenvalues[:, -1] - eigenvalues[:, -2]).tolist()
            second += (eigenvalues[:, -2] - eigenvalues[:, -3]).tolist()
    return {"representation": representation.name, "scenes": len(items), "voxels": len(top),
            "median_gap_1_2": _median(top), "median_gap_2_3": _median(second)}  # fmt: skip


def _median(values: list[float]) -> float | None:
    return statistics.median(values) if values else None


def markdown(cells: list[dict[str, Any]], threshold: float) -> str:
    def number(value: float | None) -> str:
        return "–" if value is None else f"{value:.3g}"

    text = [f"| checkpoint | representation | scenes | voxels ≥ {threshold} | median λ₁ − λ₂ | "
            "median λ₂ − λ₃ |", "|---|---|---|---|---|---|"]  # fmt: skip
    for c in cells:
        name = "/".join(Path(c["model"]).parts[-2:]) if c["model"].endswith(".pt") else c["model"]
        text.append(f"| {name} | `{c['representation']}` | {c['scenes']} | {c['voxels']} | "
                    f"{number(c['median_gap_1_2'])} | {number(c['median_gap_2_3'])} |")  # fmt: skip
    return "\n".join(text) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_checkpoint_options(
        parser,
        scenes=50,
        threshold="validity probability a voxel needs to count, the detector's threshold",
    )
    add_result_option(parser, "eigen_gap")
    args = parse_args(parser, outputs=("result",), quick={"scenes": 2},
                      also="synthetic scenes instead of a dataset")  # fmt: skip
    torch.set_num_threads(1)
    cells = per_checkpoint(args, gaps)
    table = markdown(cells, args.threshold)
    print(table, end="")
    write_result(
        args.result,
        "eigenvalue gaps of the Bingham heads' A at the voxels the detector considers",
        command_line("PYTHONPATH=src"),
        cells,
        table,
        threshold=args.threshold,
    )


if __name__ == "__main__":
    run_main(main)
