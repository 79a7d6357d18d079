"""``bingham3d``: the 3D Bingham distribution over unit quaternions of Sato et al. (2023).

Ten channels, A = triu(a) ∈ Sym₄ (row by row, `symgrasp.bingham.triu_to_sym`) over quaternions in
the scalar-last order (x, y, z, w) of `symgrasp.rotation.geometry`. B(A)(q) = B(A)(−q), so the
sign ambiguity of quaternions is built in, but the gripper flip is not: R·flip has quaternion
q ⊗ i, orthogonal to q on S³. Each ground truth therefore contributes both twins, and the loss
is the mean Bingham NLL (Eq. 13 on S³) over both twins of every valid target.

The maximum-likelihood fit to a pair {q, q ⊗ i} puts the two largest eigenvalues of A equal on
span{q, q ⊗ i}: the great circle of all rotations about the approach axis. The mode is then
arbitrary within it, which is why this faithful baseline is weak at the closing axis (Ko et al.
2024, Table 1). Decoding takes the mode (Eq. 6) with the confidence
Σᵢ (λ₄ − λᵢ).
"""

from __future__ import annotations

import torch

from symgrasp.bingham import Bingham, nll, triu_to_sym
from symgrasp.rotation.base import Decoded, Representation
from symgrasp.rotation.geometry import (
    flip_quaternion,
    matrix_to_quaternion,
    quaternion_to_matrix,
    unit,
)

Tensor = torch.Tensor


class Bingham3D(Representation):
    """[a (10)]: a Bingham distribution on S³ over the grasp quaternion; mean NLL over K."""

    name = "bingham3d"
    channels = 10
    combine = "mean"
    has_distribution = True
    has_confidence = True
    bounded_channels = slice(0, 10)

    def _target_losses(self, pred: Tensor, R: Tensor) -> Tensor:
        q = matrix_to_quaternion(R)  # [..., K, 4]
        twins = torch.cat([q, flip_quaternion(q)], dim=-2)  # [..., 2K, 4]
        # A is [..., 1, 4, 4] against 2K quaternions: `nll` decomposes it once.
        losses = nll(triu_to_sym(pred), twins)
        return losses.unflatten(-1, (2, q.shape[-2])).mean(-2)

    def _distribution(self, pred: Tensor) -> Bingham:
        return Bingham(triu_to_sym(pred))

    def _decode(self, pred: Tensor) -> Decoded:
        distribution = self._distribution(pred)
        # eigh returns unit vectors only to ~1e-6 in float32; the rotation needs better.
        rotation = quaternion_to_matrix(unit(distribution.mode))
        return Decoded(rotation, distribution.confidence)

    def _sample(self, pred: Tensor, n: int, generator: torch.Generator | None) -> Tensor:
        q = self._distribution(pred).sample((n,), generator).movedim(0, -2)
        return quaternion_to_matrix(unit(q))

    def _density_order(self, pred: Tensor, R: Tensor) -> Tensor:
        # one voxel's draws share B(A)'s normaliser: the exponent qᵀ A q orders them
        A = triu_to_sym(pred[..., None, :])
        q = matrix_to_quaternion(R)
        return (q[..., None, :] @ A @ q[..., :, None])[..., 0, 0]
