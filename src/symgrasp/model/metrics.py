"""Validation metrics of a grasp detector, accumulated over batches.

- ``validity_ap``: average precision of the validity probability over every voxel;
- ``score_mae``: mean absolute error of the gravity-rejection score at valid voxels;
- ``ex_median_deg`` / ``ez_median_deg``: median angle [deg] between the decoded approach axis
  e_x (closing axis e_z, as lines: up to the flip) and the nearest target's, at valid voxels;
- for representations with a confidence (Bingham): ``confidence_correct`` /
  ``confidence_wrong``, the mean confidence where both angles are ≤ `CORRECT_DEG` / otherwise.

The nearest target of a voxel is the one with the smallest e_x + e_z angle, so both angles
refer to the same grasp.

The metrics above judge every labelled voxel; the robot executes only the few the detector
ranks first. The **top-k metrics** judge those: per validation scene, the voxels are ranked
exactly as `symgrasp.detect.GraspDetector` ranks them with its defaults (`rank_voxels`:
validity probability ≥ `DEFAULT_VALIDITY`, Bingham confidence ≥ the representation's
``default_confidence``, score non-maximum suppression over 5³ voxels, sorted by predicted
score) and the first k are taken, for each k of `TOP_K`:

- ``top{k}_valid``: the share of those voxels that are labelled valid (a grasp of the label
  set has its TCP there);
- ``top{k}_correct``: the share that are labelled valid **and** whose decoded rotation is
  within `CORRECT_DEG` of the nearest target in both e_x and e_z (`rotation_errors`, so up to
  the flip);
- ``top{k}_valid_near`` / ``top{k}_correct_near``: the same with a voxel's 1-voxel
  neighbourhood (3³ voxels, 7.5 mm each way) standing for it: valid if any voxel there is
  labelled valid, correct if its rotation is within `CORRECT_DEG` of the nearest of their
  targets. Labels are sparse (a few hundred sampled grasps per object, each in the one voxel
  holding its TCP), so a voxel next to labelled ones is often a good grasp the labels missed;
  the strict metric counts it as a miss. Both are kept, and the selection study
  (``experiments/selection.py``) measures which one ranks checkpoints as the declutter SR does;
- ``top{k}_ex_deg`` / ``top{k}_ez_deg``: median e_x / e_z angle over the picked voxels that
  are labelled valid, pooled over scenes (NaN when there is none);
- ``top_empty``: the share of scenes where the detector would pick no voxel at all.

Shares are computed per scene over the voxels picked there (fewer than k when fewer pass the
thresholds) and averaged over scenes; a scene with no pick counts as 0 in every share.
"""

from __future__ import annotations

import math

import torch
import torch.nn.functional as F

from symgrasp.config import DEFAULT_VALIDITY
from symgrasp.model.loss import at_voxels
from symgrasp.model.network import GraspOutput
from symgrasp.model.ranking import DEFAULT_NMS_RADIUS, rank_voxels
from symgrasp.rotation import Representation

Tensor = torch.Tensor

CORRECT_DEG = 15.0
"""A prediction whose e_x and e_z are both within this angle [deg] of a target is correct."""

TOP_K = (1, 5)
"""The k of the top-k metrics: the detector's best grasp, and its best five."""

_TOP_SHARES = ("valid", "correct", "valid_near", "correct_near")


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
        self._shares: dict[tuple[int, str], list[float]] = {
            (k, name): [] for k in TOP_K for name in _TOP_SHARES
        }
        self._top_angles: dict[tuple[int, str], list[Tensor]] = {
            (k, axis): [] for k in TOP_K for axis in ("ex", "ez")
        }
        self._empty: list[bool] = []

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
        self._update_top(output, batch)

    def _update_top(self, output: GraspOutput, batch: dict[str, Tensor]) -> None:
        """The top-k metrics' per-scene parts (module docstring)."""
        representation = self.representation
        valid = batch["valid"] > 0.5
        near = F.max_pool3d(valid[:, None].float(), 3, stride=1, padding=1)[:, 0] > 0.5
        index = batch["voxel_index"]  # row r of the per-voxel labels is voxel index[r]
        row_of = torch.full(valid.shape, -1, dtype=torch.long, device=valid.device)
        row_of[tuple(index.T)] = torch.arange(len(index), device=valid.device)
        probability = output.validity.float().sigmoid()
        for b in range(len(valid)):
            ranked = rank_voxels(
                output.score[b].float(), probability[b], output.rotation[b].float().movedim(0, -1),
                representation, validity_threshold=DEFAULT_VALIDITY,
                confidence_threshold=representation.default_confidence,
                nms_radius=DEFAULT_NMS_RADIUS, top_k=max(TOP_K),
            )  # fmt: skip
            at = tuple(ranked.index.T)
            rotation = ranked.rotation.float()
            rows = row_of[b][at]
            ex, ez = _errors_at(rotation, rows[:, None], batch)
            near_rows = _neighbour_rows(row_of[b], ranked.index)
            ex_near, ez_near = _errors_at(rotation, near_rows, batch)
            hits = {
                "valid": valid[b][at],
                "correct": valid[b][at] & (ex <= CORRECT_DEG) & (ez <= CORRECT_DEG),
                "valid_near": near[b][at],
                "correct_near": near[b][at] & (ex_near <= CORRECT_DEG) & (ez_near <= CORRECT_DEG),
            }
            self._empty.append(len(rows) == 0)
            for k in TOP_K:
                for name, hit in hits.items():
                    share = hit[:k].float().mean().item() if len(hit) else 0.0
                    self._shares[k, name].append(share)
                labelled = hits["valid"][:k] & (rows[:k] >= 0)
                self._top_angles[k, "ex"].append(ex[:k][labelled].cpu())
                self._top_angles[k, "ez"].append(ez[:k][labelled].cpu())

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
        for k in TOP_K:
            for name in _TOP_SHARES:
                metrics[f"top{k}_{name}"] = _mean(torch.tensor(self._shares[k, name]))
            for axis in ("ex", "ez"):
                parts = self._top_angles[k, axis]
                angles = torch.cat(parts) if parts else torch.empty(0)
                metrics[f"top{k}_{axis}_deg"] = angles.median().item() if len(angles) else math.nan
        metrics["top_empty"] = _mean(torch.tensor(self._empty, dtype=torch.float64))
        return metrics


_OFFSETS = torch.cartesian_prod(*[torch.arange(-1, 2)] * 3)
"""The 27 voxel offsets of a 1-voxel (3³) neighbourhood."""


def _neighbour_rows(row_of: Tensor, index: Tensor) -> Tensor:
    """``[N, 27]`` label rows of the 3³ neighbourhood of each voxel of ``index`` [N, 3] (−1
    where a neighbour is not labelled or lies outside the grid); ``row_of`` [D, H, W] maps a
    voxel to its label row (−1: none)."""
    neighbours = index[:, None, :] + _OFFSETS.to(index.device)
    size = torch.tensor(row_of.shape, device=index.device)
    inside = ((neighbours >= 0) & (neighbours < size)).all(-1)
    clamped = torch.minimum(neighbours.clamp(min=0), size - 1)
    return torch.where(inside, row_of[tuple(clamped.unbind(-1))], -1)


def _errors_at(rotation: Tensor, rows: Tensor, batch: dict[str, Tensor]) -> tuple[Tensor, Tensor]:
    """e_x and e_z angles [deg] of ``rotation`` [N, 3, 3] to the nearest target of the label
    rows ``rows`` [N, J] (−1: none), pooled; NaN for a voxel without any target."""
    ex = torch.full((len(rows),), math.nan, device=rotation.device)
    ez = ex.clone()
    targets = batch["rotations"][rows.clamp(min=0)].flatten(1, 2)  # [N, J·K, 3, 3]
    mask = (batch["rotation_mask"][rows.clamp(min=0)] & (rows >= 0)[..., None]).flatten(1)
    some = mask.any(1)
    if some.any():
        ex[some], ez[some] = rotation_errors(
            rotation[some], targets[some].to(rotation.dtype), mask[some]
        )
    return ex, ez


def _mean(values: Tensor) -> float:
    return values.mean().item() if len(values) else math.nan
