"""How the validity head's probabilities meet the detector's fixed threshold, per checkpoint →
experiments/results/validity_calibration.{json,md}.

    PYTHONPATH=src python experiments/validity_calibration.py --checkpoints A.pt B.pt \\
        [--data DIR] [--scenes 40] [--threshold 0.08] [--quick [DIR]]

The detector keeps the voxels whose validity probability is at least a fixed threshold
(`DEFAULT_VALIDITY`, chosen with a BCE-trained model). A validity loss that moves the
probabilities (the focal loss without α weighting pushes the rare positives' probabilities up
and lets many negatives rise with them; Lin et al. 2017, Sec. 3.2) changes what that threshold
means, so a recipe that changes the loss changes the detector's operating point as well. Per
checkpoint, on every ``len/scenes``-th scene of the validation split of ``--data`` (default:
the checkpoint's own dataset), no augmentation: the label rate, the mean predicted probability
(equal for a calibrated head), the share of voxels at or above ``--threshold``, the precision
and recall of the labels there, and a reliability table (mean prediction and label rate per
probability bin; Guo et al. 2017). ``--quick``: the shipped Robotiq model on two synthetic
scenes.
"""

from __future__ import annotations

import argparse
import itertools
from pathlib import Path
from typing import Any

import torch
from common import add_checkpoint_options, add_result_option, per_checkpoint
from scripts import command_line, parse_args, run_main, write_result

from symgrasp.model.checkpoint import load_model

BINS = (0.0, 0.01, 0.02, 0.04, 0.08, 0.15, 0.3, 0.5, 1.0)
"""Edges of the reliability table's probability bins (fine near the threshold)."""


def calibration(
    checkpoint: str | Path, items: list[dict[str, torch.Tensor]], threshold: float
) -> dict[str, Any]:
    """The validity head of ``checkpoint`` on the scenes ``items`` (dataset items): its rates at
    ``threshold`` and per bin of `BINS`."""
    model, _ = load_model(checkpoint)
    probabilities, labels = [], []
    with torch.no_grad():
        for item in items:
            validity = model(item["tsdf"].unsqueeze(0)).validity[0]
            probabilities.append(torch.sigmoid(validity).flatten())
            labels.append(item["valid"].flatten().float())
    p, y = torch.cat(probabilities).double(), torch.cat(labels).double()
    kept = p >= threshold
    bins = []
    for low, high in itertools.pairwise(BINS):
        inside = (p >= low) & ((p < high) if high < 1 else (p <= high))
        bins.append({"from": low, "to": high, "voxels": int(inside.sum()),
                     "mean_prediction": _mean(p[inside]), "label_rate": _mean(y[inside])})  # fmt: skip
    return {
        "checkpoint": str(checkpoint),
        "scenes": len(items),
        "voxels": len(p),
        "label_rate": _mean(y),
        "mean_prediction": _mean(p),
        "kept_share": _mean(kept.double()),
        "precision": _mean(y[kept]),
        "recall": _mean(kept[y > 0].double()),
        "bins": bins,
    }


def _mean(values: torch.Tensor) -> float | None:
    return float(values.mean()) if len(values) else None


def markdown(cells: list[dict[str, Any]], threshold: float) -> str:
    def name(model: str) -> str:  # a checkpoint by its run: RUN/best.pt
        return "/".join(Path(model).parts[-2:]) if model.endswith(".pt") else model

    def pct(value: float | None, digits: int = 2) -> str:
        return "–" if value is None else f"{100 * value:.{digits}f}"

    text = [f"| checkpoint | scenes | label rate % | mean prediction % | voxels ≥ {threshold} % | "
            f"precision there % | recall % |", "|---|---|---|---|---|---|---|"]  # fmt: skip
    for c in cells:
        text.append(
            f"| {name(c['model'])} | {c['scenes']} | {pct(c['label_rate'], 3)} | "
            f"{pct(c['mean_prediction'], 3)} | {pct(c['kept_share'], 3)} | "
            f"{pct(c['precision'], 1)} | {pct(c['recall'], 1)} |"
        )
    text += ["", "Reliability (mean prediction % / label rate % [voxels] per probability bin):", "",
             "| checkpoint | " + " | ".join(f"{b['from']}–{b['to']}" for b in cells[0]["bins"])
             + " |", "|---|" + "---|" * len(cells[0]["bins"])]  # fmt: skip
    for c in cells:
        text.append(f"| {name(c['model'])} | " + " | ".join(
            f"{pct(b['mean_prediction'], 1)} / {pct(b['label_rate'], 1)} [{b['voxels']}]"
            for b in c["bins"]) + " |")  # fmt: skip
    return "\n".join(text) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_checkpoint_options(parser, scenes=40, threshold="the detector's validity threshold")
    add_result_option(parser, "validity_calibration")
    args = parse_args(parser, outputs=("result",), quick={"scenes": 2},
                      also="synthetic scenes instead of a dataset")  # fmt: skip
    torch.set_num_threads(1)
    cells = per_checkpoint(args, calibration)
    table = markdown(cells, args.threshold)
    print(table, end="")
    write_result(
        args.result,
        "the validity head's probabilities against the detector's threshold",
        command_line("PYTHONPATH=src"),
        cells,
        table,
        threshold=args.threshold,
        bins=BINS,
    )


if __name__ == "__main__":
    run_main(main)
