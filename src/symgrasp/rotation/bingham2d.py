"""``bingham2d``: the planar-symmetric representation of Ko et al. (2024), Sec. 3.2.

Nine channels [a ∈ R⁶, x ∈ R³] (Eq. 7): A = triu(a) ∈ Sym₃ parametrises a 2D Bingham
distribution B(A) over the closing axis e_z, and x is the approach axis e_x. B(A)(v) = B(A)(−v),
so one parameter set stands for a grasp and its 180°-flipped twin (e_z → −e_z, e_x unchanged),
and the loss (Eq. 8) is exactly invariant to the flip:

    L = (1 − cos(x, e_x)) + L_BNLL(A, e_z),    L_BNLL = −e_zᵀ A e_z + log C(λ(A))

(Eq. 13), the two terms added without scaling as in the paper. Decoding takes e_z as
the mode of B(A), the eigenvector of the largest eigenvalue (Eq. 6), or a
sample of B(A); Gram–Schmidt then keeps e_x (Sec. 3.3). The confidence is
(λ₃ − λ₂) + (λ₃ − λ₁); the paper discards grasps below `PAPER_CONFIDENCE_THRESHOLD` (Sec. 4.3).
"""

from __future__ import annotations

import torch

from symgrasp.bingham import Bingham, nll, triu_to_sym
from symgrasp.rotation.base import Decoded, Representation
from symgrasp.rotation.geometry import gram_schmidt, unit

Tensor = torch.Tensor

PAPER_CONFIDENCE_THRESHOLD = 15.0
"""Grasps with (λ₃ − λ₂) + (λ₃ − λ₁) below this were masked out in Ko et al. (2024), Table 1."""


class Bingham2D(Representation):
    """[a (6), x (3)]: a 2D Bingham over the closing axis e_z and the approach axis e_x.

    ``a`` is the upper triangle of A row by row (`symgrasp.bingham.triu_to_sym`). With K targets
    the loss is the mean over valid targets. The cosine is x̂·e_x with x̂ = x / max(|x|, 1e-8)
    (`unit`): its gradient at x = 0 is the finite −e_x/1e-8, so a zero-initialised x head starts
    with large steps.
    """

    name = "bingham2d"
    channels = 9
    combine = "mean"
    has_distribution = True
    has_confidence = True
    default_confidence = PAPER_CONFIDENCE_THRESHOLD
    bounded_channels = slice(0, 6)  # a of A = triu(a); e_x is a plain vector
    closing_axis_up_to_sign = True

    def _target_losses(self, pred: Tensor, R: Tensor) -> Tensor:
        # A is [..., 1, 3, 3] against K targets: `nll` decomposes it once, not K times.
        A, x = triu_to_sym(pred[..., :6]), pred[..., 6:]
        approach = 1 - (unit(x) * R[..., 0]).sum(-1)
        return approach + nll(A, R[..., 2])

    def _distribution(self, pred: Tensor) -> Bingham:
        return Bingham(triu_to_sym(pred[..., :6]))

    def _decode(self, pred: Tensor) -> Decoded:
        distribution = self._distribution(pred)
        rotation = gram_schmidt(pred[..., 6:], distribution.mode)
        return Decoded(rotation, distribution.confidence)

    def _sample(self, pred: Tensor, n: int, generator: torch.Generator | None) -> Tensor:
        closing = self._distribution(pred).sample((n,), generator).movedim(0, -2)
        return gram_schmidt(pred[..., None, 6:], closing)

    def _density_order(self, pred: Tensor, R: Tensor) -> Tensor:
        # one voxel's draws share B(A)'s normaliser: the exponent e_zᵀ A e_z orders them
        A = triu_to_sym(pred[..., None, :6])
        e_z = R[..., 2]
        return (e_z[..., None, :] @ A @ e_z[..., :, None])[..., 0, 0]
