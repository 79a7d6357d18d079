"""Validation metrics of a grasp detector, accumulated over batches.

- ``validity_ap``: average precision of the validity probability over every voxel;
- ``score_mae``: mean absolute error of the gravity-rejection score at valid voxels;
- ``ex_median_deg`` / ``ez_median_deg``: median angle [deg] between the decoded approach axis
  e_x (closing axis e_z, as lines: up to the flip) and the nearest target's, at valid voxels;
- for representations with a confidence (Bingham): ``confidence_correct`` /
  ``confidence_wrong``, the mean confidence where both angles are ≤ `CORRECT_DEG` / otherwise.

The nearest target of a voxel is the one with the smallest e_x + e_z angle, so both angles
refer to the same grasp.
"""

from __future__ import annotations

import math

import torch

from symgrasp.model.loss import at_voxels
from symgrasp.model.network import GraspOutput
from symgrasp.rotation import Representation

Tensor = torch.Tensor

CORRECT_DEG = 15.0
"""A prediction whose e_x and e_z are both within this angle [deg] of a target is correct."""


def average_precision(probability: Tensor, label: Tensor) -> float:
    """Area under the precision–recall curve as the mean precision at each positive.

    ``probability``, ``label`` ``[N]``; ties are broken by order after a stable sort (descending).
    NaN if there is no positive.
    """
    if probability.shape != label.shape or probability.ndim != 1:
        raise ValueError(
            f"probability and label must be [N] of equal shape, "
            f"got {tuple(probability.shape)} and {tuple(label.shape)}"
        )
    order = torch.sort(probability, descending=True, stable=True).indices
    positive = label[order].bool()
    if not positive.any():
        return math.nan
    hits = positive.double().cumsum(0)
    rank = torch.arange(1, len(order) + 1, dtype=torch.float64)
    return (hits / rank)[positive].mean().item()


def rotation_errors(R_pred: Tensor, R_gt: Tensor, mask: Tensor) -> tuple[Tensor, Tensor]:
    """Angles [deg] of e_x and of the line of e_z to the nearest valid target.

    Args:
        R_pred: ``[M, 3, 3]`` predicted rotations.
        R_gt: ``[M, K, 3, 3]`` targets; ``mask [M, K]`` marks the valid ones (≥ 1 per row).

    Returns:
        ``(ex_deg [M], ez_deg [M])``, invariant to flipping the prediction or a target.
    """
    cos_x = (R_pred[:, None, :, 0] * R_gt[..., 0]).sum(-1).clamp(-1, 1)
    cos_z = (R_pred[:, None, :, 2] * R_gt[..., 2]).sum(-1).abs().clamp(max=1)
    ex, ez = torch.rad2deg(torch.acos(cos_x)), torch.rad2deg(torch.acos(cos_z))
    nearest = (ex + ez).masked_fill(~mask, torch.inf).argmin(-1, keepdim=True)
    return ex.gather(-1, nearest)[:, 0], ez.gather(-1, nearest)[:, 0]


class MetricAccumulator:
    """Collects what the metrics need batch by batch (on the CPU); `compute` finishes them."""

    def __init__(self, representation: Representation) -> None:
        self.representation = representation
        self._parts: dict[str, list[Tensor]] = {
            key: [] for key in ("probability", "valid", "score_error", "ex", "ez", "confidence")
        }

    @torch.no_grad()
    def update(self, output: GraspOutput, batch: dict[str, Tensor]) -> None:
        index = batch["voxel_index"]
        self._parts["probability"].append(output.validity.float().sigmoid().flatten().cpu())
        self._parts["valid"].append(batch["valid"].flatten().cpu())
        score_error = at_voxels(output.score.float(), index) - at_voxels(batch["score"], index)
        self._parts["score_error"].append(score_error.abs().cpu())
        decoded = self.representation.decode(at_voxels(output.rotation.float(), index))
        ex, ez = rotation_errors(decoded.rotation, batch["rotations"], batch["rotation_mask"])
        self._parts["ex"].append(ex.cpu())
        self._parts["ez"].append(ez.cpu())
        if decoded.confidence is not None:
            self._parts["confidence"].append(decoded.confidence.float().cpu())

    def compute(self) -> dict[str, float]:
        """The metrics named in the module docstring (NaN where undefined)."""
        parts = {
            key: torch.cat(value) if value else torch.empty(0) for key, value in self._parts.items()
        }
        ex, ez = parts["ex"], parts["ez"]
        metrics = {
            "validity_ap": average_precision(parts["probability"], parts["valid"]),
            "score_mae": _mean(parts["score_error"]),
            "ex_median_deg": ex.median().item() if len(ex) else math.nan,
            "ez_median_deg": ez.median().item() if len(ez) else math.nan,
        }
        if len(parts["confidence"]):
            correct = (ex <= CORRECT_DEG) & (ez <= CORRECT_DEG)
            metrics["confidence_correct"] = _mean(parts["confidence"][correct])
            metrics["confidence_wrong"] = _mean(parts["confidence"][~correct])
        return metrics


def _mean(values: Tensor) -> float:
    return values.mean().item() if len(values) else math.nan
