"""``rotmat6d`` and ``rotmat6d_naive``: the 6-D representation of Zhou et al. (2019).

"On the Continuity of Rotation Representations in Neural Networks" (CVPR 2019) regresses two
columns of the rotation matrix and completes them by Gram–Schmidt. As in the paper's baseline
(Ko et al. 2024, Sec. 3.3, after PVGN), the two columns are the approach axis e_x and the closing
axis e_z, pred = [x (3), z (3)], and decoding keeps e_x: e_x = x/|x|,
e_z = normalize(z − (e_x·z) e_x), e_y = e_z × e_x (`gram_schmidt`).

The loss is the sum of one cosine term per column,

    L(R) = (1 − cos(x, e_x)) + (1 − cos(z, e_z)),

the approach term being the same as ``bingham2d``'s so that the two differ only in how e_z is
modelled (and 1 − cos(x, e) = ½ |x/|x| − e|², half the squared error of the unit-normalised
column). ``rotmat6d``
evaluates it for the ground truth and its flipped twin (e_z → −e_z) and keeps the smaller, as S4G
and VGN do (Sec. 4): min(L(R), L(R·flip)) = (1 − cos(x, e_x)) + (1 − |cos(z, e_z)|).
``rotmat6d_naive`` uses L(R) alone: the ablation where a network shown both twins is pulled
towards +e_z and −e_z equally (the two gradients cancel in expectation), so its closing axis is
left arbitrary — mode averaging.
"""

from __future__ import annotations

from typing import ClassVar

import torch

from symgrasp.rotation.base import Decoded, Representation
from symgrasp.rotation.geometry import gram_schmidt, unit

Tensor = torch.Tensor


class RotMat6D(Representation):
    """[x (3), z (3)] regressing e_x and e_z; loss minimised over the flip, min over K targets.

    cos(x, e) = x̂·e with x̂ = x / max(|x|, 1e-8) (`unit`; e is a column of a rotation, so
    unit): at x = 0 the gradient is finite but large (1e8).
    """

    name = "rotmat6d"
    channels = 6
    combine = "min"
    flip_symmetric: ClassVar[bool] = True

    def _target_losses(self, pred: Tensor, R: Tensor) -> Tensor:
        approach = 1 - (unit(pred[..., :3]) * R[..., 0]).sum(-1)
        closing = (unit(pred[..., 3:]) * R[..., 2]).sum(-1)
        return approach + 1 - (closing.abs() if self.flip_symmetric else closing)

    def _decode(self, pred: Tensor) -> Decoded:
        return Decoded(gram_schmidt(pred[..., :3], pred[..., 3:]), None)


class RotMat6DNaive(RotMat6D):
    """`RotMat6D` without the flip minimum (ablation: mode averaging)."""

    name = "rotmat6d_naive"
    flip_symmetric = False
