"""How the detector picks grasps from the network's per-voxel outputs, as one pure function.

`rank_voxels` is what `symgrasp.detect.GraspDetector` runs after the network (its steps 2–6,
docs/detect.md) and what the validation metrics rank with (`symgrasp.model.metrics`, the
``top{k}_*`` metrics), so that a metric about "the grasps the detector would pick" picks the
same voxels. Pure torch: no TSDF fusion, gripper or simulator.
"""

from __future__ import annotations

from typing import NamedTuple

import torch
import torch.nn.functional as F

from symgrasp.config import DEFAULT_VALIDITY
from symgrasp.rotation import Representation

Tensor = torch.Tensor

DEFAULT_NMS_RADIUS = 2
"""The detector's non-maximum suppression radius [voxels]: a (2r+1)³ neighbourhood."""


class Ranked(NamedTuple):
    """The voxels the detector keeps, best gravity-rejection score first."""

    index: Tensor
    """``[N, 3]`` voxel indices (i, j, k)."""
    pred: Tensor
    """``[N, C]`` the representation's channels at those voxels (float64)."""
    rotation: Tensor
    """``[N, 3, 3]`` decoded rotations (the mode)."""
    confidence: Tensor | None
    """``[N]`` Bingham confidence, or None for a representation without one."""
    score: Tensor
    """``[N]`` predicted score."""


def rank_voxels(
    score: Tensor,
    validity: Tensor,
    rotation: Tensor,
    representation: Representation,
    *,
    validity_threshold: float = DEFAULT_VALIDITY,
    confidence_threshold: float | None = None,
    nms_radius: int = DEFAULT_NMS_RADIUS,
    top_k: int | None = None,
    keep: Tensor | None = None,
) -> Ranked:
    """The voxels a detector with these options turns into grasps, ranked.

    Keeps voxels whose validity probability is ≥ ``validity_threshold`` (and ``keep``, a bool
    volume, where given), decodes their rotations, drops those whose confidence is below
    ``confidence_threshold`` (None: no threshold; ignored for a representation without a
    confidence), keeps those whose score is the highest among the surviving voxels within
    ``nms_radius`` voxels (ties all survive; 0: no suppression), sorts by score (descending,
    stable) and keeps the first ``top_k`` (None: all).

    Args:
        score: ``[D, H, W]`` predicted score.
        validity: ``[D, H, W]`` validity **probability** (not the logit).
        rotation: ``[D, H, W, C]`` the representation's channels.
    """
    candidate = validity >= validity_threshold
    if keep is not None:
        candidate &= keep
    index = candidate.nonzero()  # [M, 3]
    pred = rotation[candidate].double()
    decoded = representation.decode(pred)
    rotations, confidence = decoded.rotation, decoded.confidence
    if confidence_threshold is not None and confidence is not None:
        confident = confidence >= confidence_threshold
        index, pred, confidence = index[confident], pred[confident], confidence[confident]
        rotations = rotations[confident]
    if nms_radius and len(index):
        local_max = local_maxima(score, index, nms_radius)
        index, pred, rotations = index[local_max], pred[local_max], rotations[local_max]
        confidence = None if confidence is None else confidence[local_max]
    voxel_score = score[tuple(index.T)]
    order = torch.argsort(voxel_score, descending=True, stable=True)
    if top_k is not None:
        order = order[:top_k]
    return Ranked(
        index[order],
        pred[order],
        rotations[order],
        None if confidence is None else confidence[order],
        voxel_score[order],
    )


def local_maxima(score: Tensor, index: Tensor, radius: int) -> Tensor:
    """Which of the candidate voxels ``index`` [M, 3] hold the highest ``score`` [D, H, W]
    among the candidates within ``radius`` voxels (a bool ``[M]``)."""
    # Only the candidates' bounding box, grown by the radius, can hold a neighbour: pooling it
    # alone gives the same maxima at a fraction of the whole grid's cost.
    lo = (index.min(dim=0).values - radius).clamp_min(0)
    hi = index.max(dim=0).values + radius + 1
    box = score[lo[0] : hi[0], lo[1] : hi[1], lo[2] : hi[2]]
    at = tuple((index - lo).T)
    candidates = torch.full_like(box, -torch.inf)
    candidates[at] = box[at]
    pooled = candidates[None, None]
    for axis in range(3):  # a box's maximum, one axis at a time: 3·(2r+1) reads, not (2r+1)³
        kernel, padding = [1, 1, 1], [0, 0, 0]
        kernel[axis], padding[axis] = 2 * radius + 1, radius
        pooled = F.max_pool3d(pooled, kernel, stride=1, padding=padding)
    return candidates[at] >= pooled[0, 0][at]
