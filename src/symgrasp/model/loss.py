"""The training loss: validity BCE (or focal) + score L2 + the representation's rotation loss.

Following the paper (Appx. C), with a batch from `symgrasp.data.dataset.collate_scenes`:

- **validity**: binary cross-entropy of the validity logit against ``valid``, summed over every
  voxel of the batch and divided by the number of valid voxels; or, with
  ``ValidityLoss("focal", γ, α)``, the focal loss of Lin et al. 2017,
  −α_t (1 − p_t)^γ log p_t per voxel (p_t the predicted probability of the voxel's label,
  α_t = α at valid voxels and 1 − α elsewhere, or 1 without α), normalised the same way;
  with ``ValidityLoss(ignore_band=d)``, the invalid voxels within Chebyshev distance d of a
  valid voxel of their scene (`ignored_voxels`) are left out of the sum: a voxel beside a
  labelled grasp often holds a grasp that was not sampled, and teaching it as invalid is
  teaching noise (docs/reports/label-density.md, "False negatives");
- **score**: squared error of the gravity-rejection score at the valid voxels, mean over them
  (elsewhere the label is 0 by convention, not a measurement; the validity head covers it);
- **rotation**: ``representation.loss(pred, rotations, rotation_mask)`` (Eq. 8 for
  ``bingham2d``) at the valid voxels, every target of a voxel, mean over the voxels.

All three terms are thus "per valid voxel". Valid voxels are rare (≈ 0.2–2 % of the grid): the
plain mean over all voxels made the validity term hundreds of times weaker than the rotation
term per valid voxel, and the shared features learnt only rotations. Dividing the sum by the
valid count rescales the term but keeps the relative weight of positives and negatives, so the
predicted probability stays calibrated (unlike class-balanced weights). The total is the
weighted sum of the three; the default weights are all 1 (``docs/model.md`` says why).
"""

from __future__ import annotations

import torch
import torch.nn.functional as F

from symgrasp.config import LossWeights, ValidityLoss
from symgrasp.model.network import GraspOutput
from symgrasp.rotation import Representation

Tensor = torch.Tensor


def at_voxels(volume: Tensor, voxel_index: Tensor) -> Tensor:
    """Values of ``volume [B, D, H, W]`` or ``[B, C, D, H, W]`` at ``voxel_index [M, 4]``.

    Returns ``[M]`` or ``[M, C]``; rows of ``voxel_index`` are (b, i, j, k).
    """
    b, i, j, k = voxel_index.unbind(1)
    if volume.ndim == 5:
        return volume[b, :, i, j, k]
    return volume[b, i, j, k]


def focal_loss(logits: Tensor, labels: Tensor, gamma: float, alpha: float | None) -> Tensor:
    """Per-element focal loss −α_t (1 − p_t)^γ log p_t (Lin et al. 2017) of ``logits`` against
    ``labels`` in {0, 1} (same shape, float); γ = 0 without α is the cross-entropy exactly."""
    cross_entropy = F.binary_cross_entropy_with_logits(logits, labels, reduction="none")
    loss = cross_entropy
    if gamma != 0:
        # 1 − p_t = 1 − exp(−CE), accurate for small CE; kept above 0 so that γ < 1 has a
        # finite gradient where p_t rounds to 1
        miss = (-torch.expm1(-cross_entropy)).clamp_min(torch.finfo(logits.dtype).tiny)
        loss = loss * miss.pow(gamma)
    if alpha is not None:
        loss = loss * (alpha * labels + (1 - alpha) * (1 - labels))
    return loss


def ignored_voxels(valid: Tensor, band: int) -> Tensor:
    """The invalid voxels of ``valid`` [B, D, H, W] (0 or 1) within Chebyshev distance
    ``band`` [voxels] of a valid voxel of the same scene: bool, same shape."""
    near = F.max_pool3d(valid[:, None], kernel_size=2 * band + 1, stride=1, padding=band)
    return (near[:, 0] > 0) & (valid == 0)


def _validity_sum(logits: Tensor, labels: Tensor, loss: ValidityLoss | None) -> Tensor:
    """The validity loss of ``logits`` [B, D, H, W] against ``labels`` (same shape, 0 or 1),
    summed over the voxels (those `ignored_voxels` leaves in, with an ignore band)."""
    if loss is None or (loss.kind == "bce" and not loss.ignore_band):
        return F.binary_cross_entropy_with_logits(logits, labels, reduction="sum")
    if loss.kind == "bce":
        per_voxel = F.binary_cross_entropy_with_logits(logits, labels, reduction="none")
    else:
        per_voxel = focal_loss(logits, labels, loss.focal_gamma, loss.focal_alpha)
    if loss.ignore_band:
        per_voxel = per_voxel.masked_fill(ignored_voxels(labels, loss.ignore_band), 0.0)
    return per_voxel.sum()


def grasp_losses(
    output: GraspOutput,
    batch: dict[str, Tensor],
    representation: Representation,
    weights: LossWeights | None = None,
    validity_loss: ValidityLoss | None = None,
) -> dict[str, Tensor]:
    """``{"total", "validity", "score", "rotation"}`` scalar losses of one batch.

    The rotation loss runs in float32 (the Bingham normaliser in float64 inside it) whatever
    the network's precision. A batch without valid voxels has score and rotation losses 0.
    ``validity_loss``: binary cross-entropy by default.
    """
    weights = weights or LossWeights()
    index = batch["voxel_index"]
    validity = _validity_sum(output.validity.float(), batch["valid"], validity_loss) / max(
        len(index), 1
    )
    if len(index) == 0:
        zero = output.score.float().sum() * 0 + output.rotation.float().sum() * 0
        score, rotation_loss = zero, zero
    else:
        score_error = at_voxels(output.score.float(), index) - at_voxels(batch["score"], index)
        score = score_error.square().mean()
        pred = at_voxels(output.rotation.float(), index)
        rotation_loss = representation.loss(pred, batch["rotations"], batch["rotation_mask"]).mean()
    total = weights.validity * validity + weights.score * score + weights.rotation * rotation_loss
    return {"total": total, "validity": validity, "score": score, "rotation": rotation_loss}
