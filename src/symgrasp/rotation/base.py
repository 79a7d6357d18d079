"""The interface every rotation representation implements, and how K targets are combined.

A network predicts ``pred [..., C]`` per element (a voxel, a point). Training compares it with
``R_gt [..., 3, 3]``, or with ``R_gt [..., K, 3, 3]``: K alternative ground-truth grasps per
element (several valid grasps in one voxel) with ``mask [..., K]`` marking the real ones.

The per-target losses ``[..., K]`` are combined according to what the representation is:

- a **distribution** (``bingham2d``, ``bingham3d``) is fitted to all valid targets: the loss is
  their mean negative log-likelihood (the likelihood of the K grasps as independent draws);
- a **regression** (``rotmat6d``, ``rotmat6d_naive``, ``quaternion``) predicts one rotation, so
  it is charged for the nearest valid target: the minimum.

Masked-out targets may hold anything (padding, even NaN): they are replaced by the identity
before any arithmetic and do not reach the loss or its gradient. An element whose targets are
all masked out has loss 0 and zero gradient.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import TYPE_CHECKING, ClassVar, Literal, NamedTuple

import torch

if TYPE_CHECKING:
    from symgrasp.bingham import Bingham

Tensor = torch.Tensor


class Decoded(NamedTuple):
    """What `Representation.decode` returns."""

    rotation: Tensor
    """``[..., 3, 3]`` proper rotations [e_x e_y e_z]."""
    confidence: Tensor | None
    """``[...]`` where the representation defines one (the Bingham ones), else None."""


class Representation(ABC):
    """A rotation representation: its channel count, training loss, decoder and sampler."""

    name: ClassVar[str]
    channels: ClassVar[int]
    combine: ClassVar[Literal["mean", "min"]]
    """How the losses of K targets are combined (see the module docstring)."""
    has_distribution: ClassVar[bool] = False
    """Whether `sample` is defined."""
    has_confidence: ClassVar[bool] = False
    """Whether `decode` returns a confidence (the Bingham eigenvalue gaps)."""
    default_confidence: ClassVar[float | None] = None
    """The confidence threshold a detector applies unless told otherwise (None: none)."""
    bounded_channels: ClassVar[slice | None] = None
    """The channels the network soft-clips (a Bingham parameter matrix grows without bound on
    targets that share one axis, see `symgrasp.model.network`); None: none."""
    closing_axis_up_to_sign: ClassVar[bool] = False
    """Whether the decoded closing axis e_z has no meaningful sign (±e_z are one parameter
    set), so that a flip of e_z between neighbouring outputs is no change."""

    def loss(self, pred: Tensor, R_gt: Tensor, mask: Tensor | None = None) -> Tensor:
        """Per-element training loss.

        Args:
            pred: ``[..., C]`` network output.
            R_gt: ``[..., 3, 3]`` ground-truth rotation, or ``[..., K, 3, 3]`` K alternatives.
            mask: ``[..., K]`` bool, True for the valid targets; only with K targets.

        Returns:
            ``[...]``: the mean over valid targets for distributions, the minimum for
            regressions, 0 where every target is masked out.
        """
        self._check_pred(pred)
        targets, mask = self._as_targets(pred, R_gt, mask)
        losses = self._target_losses(pred.unsqueeze(-2), targets)
        return _combine(losses, mask, self.combine)

    def decode(self, pred: Tensor) -> Decoded:
        """The predicted rotation ``[..., 3, 3]`` (and confidence ``[...]`` where defined)."""
        self._check_pred(pred)
        return self._decode(pred)

    def sample(self, pred: Tensor, n: int, generator: torch.Generator | None = None) -> Tensor:
        """``n`` rotations drawn from the predicted distribution, ``[..., n, 3, 3]``."""
        if not self.has_distribution:
            raise NotImplementedError(
                f"{self.name}: a point estimate defines no distribution to sample; "
                "use decode() instead"
            )
        self._check_pred(pred)
        if n < 0:
            raise ValueError(f"{self.name}: `n` must be non-negative, got {n}")
        return self._sample(pred, n, generator)

    def fallbacks(self, pred: Tensor, k: int, generator: torch.Generator | None = None) -> Tensor:
        """``k`` other rotations of each element, most plausible first, ``[..., k, 3, 3]``: what
        a detector tries when the decoded rotation's approach is refused.

        A distribution draws them (`sample`) and orders them by their density under it, most
        probable first (`_density_order`; for ``bingham2d`` the closing axis is drawn from B(A)
        and Gram–Schmidt keeps e_x: the paper's third decoding mode, Sec. 3.3). A point estimate
        has nothing to draw from: its fallbacks are the control a user would try, the decoded
        rotation turned about its approach axis e_x by multiples of 180°/(k + 1), nearest turn
        first (`yaw_turns`); a turn of 180° is the same grasp, so the k turns cover the others
        evenly."""
        self._check_pred(pred)
        if isinstance(k, bool) or not isinstance(k, int) or k < 0:
            raise ValueError(f"{self.name}: `k` must be an integer ≥ 0, got {k!r}")
        if not self.has_distribution:
            return yaw_turns(self._decode(pred).rotation, k)
        drawn = self._sample(pred, k, generator)
        order = torch.argsort(
            self._density_order(pred, drawn), dim=-1, descending=True, stable=True
        )
        return torch.take_along_dim(drawn, order[..., None, None], dim=-3)

    def _density_order(self, pred: Tensor, R: Tensor) -> Tensor:
        """A key ``[..., n]`` that orders rotations ``R [..., n, 3, 3]`` of elements ``pred``
        like their density under the predicted distribution (distributions only)."""
        raise NotImplementedError

    def distribution(self, pred: Tensor) -> Bingham:
        """The predicted Bingham distribution, batch shape ``[...]``: of the closing axis e_z
        on S² (`bingham2d`) or of the grasp quaternion on S³ (`bingham3d`)."""
        if not self.has_distribution:
            raise NotImplementedError(f"{self.name}: a point estimate defines no distribution")
        self._check_pred(pred)
        return self._distribution(pred)

    @abstractmethod
    def _target_losses(self, pred: Tensor, R: Tensor) -> Tensor:
        """Loss against each target: ``pred [..., 1, C]``, ``R [..., K, 3, 3]`` → ``[..., K]``."""

    @abstractmethod
    def _decode(self, pred: Tensor) -> Decoded: ...

    def _sample(self, pred: Tensor, n: int, generator: torch.Generator | None) -> Tensor:
        raise NotImplementedError

    def _distribution(self, pred: Tensor) -> Bingham:
        raise NotImplementedError

    def _check_pred(self, pred: Tensor) -> None:
        if pred.ndim == 0 or pred.shape[-1] != self.channels:
            raise ValueError(
                f"{self.name}: `pred` must be [..., {self.channels}] ({self.channels} channels), "
                f"got shape {tuple(pred.shape)}"
            )
        if not pred.is_floating_point():
            raise ValueError(f"{self.name}: `pred` must be floating point, got {pred.dtype}")

    def _as_targets(
        self, pred: Tensor, R_gt: Tensor, mask: Tensor | None
    ) -> tuple[Tensor, Tensor | None]:
        """``R_gt`` as ``[..., K, 3, 3]`` with masked-out targets replaced by the identity."""
        batch = tuple(pred.shape[:-1])
        shape = tuple(R_gt.shape)
        if shape[-2:] == (3, 3) and shape[:-2] == batch:
            if mask is not None:
                raise ValueError(
                    f"{self.name}: `mask` needs K targets, R_gt [..., K, 3, 3]; got R_gt {shape}"
                )
            return R_gt.unsqueeze(-3), None
        if shape[-2:] != (3, 3) or shape[:-3] != batch or len(shape) != len(batch) + 3:
            raise ValueError(
                f"{self.name}: `R_gt` must be [..., 3, 3] or [..., K, 3, 3] with the batch shape "
                f"{batch} of `pred` {tuple(pred.shape)}, got shape {shape}"
            )
        if shape[-3] == 0:
            raise ValueError(f"{self.name}: `R_gt` must hold K ≥ 1 targets, got shape {shape}")
        if mask is None:
            return R_gt, None
        if tuple(mask.shape) != shape[:-2] or mask.dtype != torch.bool:
            raise ValueError(
                f"{self.name}: `mask` must be bool [..., K] = {shape[:-2]}, "
                f"got {mask.dtype} {tuple(mask.shape)}"
            )
        identity = torch.eye(3, dtype=R_gt.dtype, device=R_gt.device)
        return torch.where(mask[..., None, None], R_gt, identity), mask

    def __repr__(self) -> str:
        return f"{type(self).__name__}(name={self.name!r}, channels={self.channels})"


def _combine(losses: Tensor, mask: Tensor | None, how: Literal["mean", "min"]) -> Tensor:
    """``[..., K]`` → ``[...]``: masked mean or masked minimum, 0 where all are masked out."""
    if how == "mean":
        if mask is None:
            return losses.mean(-1)
        weights = mask.to(losses.dtype)
        return (losses * weights).sum(-1) / weights.sum(-1).clamp(min=1)
    if mask is None:
        return losses.amin(-1)
    nearest = losses.masked_fill(~mask, torch.inf).amin(-1)
    return torch.where(mask.any(-1), nearest, torch.zeros_like(nearest))


def yaw_turns(R: Tensor, k: int) -> Tensor:
    """``R [..., 3, 3]`` turned about its own approach axis e_x by j·180°/(k + 1), j = 1 … k,
    nearest turn first (j and k + 1 − j, the same angle either way up to the gripper's flip,
    ordered by min(j, k + 1 − j), then j): ``[..., k, 3, 3]``. e_x is kept exactly."""
    j = torch.arange(1, k + 1, dtype=torch.long)
    j = j[torch.argsort(torch.minimum(j, k + 1 - j) * (k + 1) + j, stable=True)]
    angle = (j.to(R.dtype) * torch.pi / (k + 1)).to(R.device)
    c, s = torch.cos(angle), torch.sin(angle)
    turn = torch.zeros(k, 3, 3, dtype=R.dtype, device=R.device)  # about x, in the grasp frame
    turn[:, 0, 0] = 1
    turn[:, 1, 1], turn[:, 1, 2], turn[:, 2, 1], turn[:, 2, 2] = c, -s, s, c
    return R[..., None, :, :] @ turn
