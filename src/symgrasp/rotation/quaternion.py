"""``quaternion``: VGN's 4-channel unit quaternion (Breyer et al. 2020), scalar-last (x, y, z, w).

The loss is 1 − |⟨q̂, q⟩| with q̂ = pred/|pred| (|⟨q̂, q⟩| = cos(θ/2) for the angle θ between the
rotations, and the absolute value makes q and −q equal), minimised over the ground truth and its
flipped twin as in VGN: 1 − max(|⟨q̂, q⟩|, |⟨q̂, q ⊗ i⟩|). Decoding normalises (zero → identity).
"""

from __future__ import annotations

import torch

from symgrasp.rotation.base import Decoded, Representation
from symgrasp.rotation.geometry import (
    flip_quaternion,
    matrix_to_quaternion,
    normalize,
    quaternion_to_matrix,
    unit,
)

Tensor = torch.Tensor


class Quaternion(Representation):
    """[x, y, z, w]; loss minimised over the flip, min over K targets.

    q̂ = pred / max(|pred|, 1e-8) (`unit`): the gradient at pred = 0 is finite.
    """

    name = "quaternion"
    channels = 4
    combine = "min"

    def _target_losses(self, pred: Tensor, R: Tensor) -> Tensor:
        q = matrix_to_quaternion(R)
        q_hat = unit(pred)
        alignment = torch.maximum(
            (q_hat * q).sum(-1).abs(), (q_hat * flip_quaternion(q)).sum(-1).abs()
        )
        return 1 - alignment

    def _decode(self, pred: Tensor) -> Decoded:
        identity = pred.new_tensor([0.0, 0.0, 0.0, 1.0])
        return Decoded(quaternion_to_matrix(normalize(pred, identity)), None)
