"""The volumetric grasp detector: a 3D encoder–decoder over the TSDF and three per-voxel heads.

The layout follows the paper's detector (Ko et al. 2024, Sec. 3.3, Fig. 2; after
the gravity-aware VGN of Ko et al. 2023): the 40³ TSDF goes through a fully-convolutional
encoder–decoder to a 40³ × 16 feature volume, read by three 1×1×1 convolutional heads:

- ``score``: gravity-rejection score (1 channel, linear);
- ``validity``: grasp-validity logit (1 channel);
- ``rotation``: the rotation representation's C channels (`symgrasp.rotation`).

Only the rotation head depends on the representation. The network is sized for a CPU: the
encoder halves the resolution three times (40³ → 20³ → 10³ → 5³) with 3×3×3 convolutions, and
the decoder upsamples trilinearly and adds the encoder's features back at each scale (U-Net
skips: sums at 10³ and 20³, a concatenation at 40³), so full-resolution detail survives with
only a pointwise layer at 40³. Every 3×3×3 convolution is followed by GroupNorm (4 groups) and
ReLU. With the default widths (8, 16, 32, 64) a forward pass costs ≈ 0.39 GFLOP per volume
(`count_flops`), ≈ 222 k parameters.

Design choices measured on one synthetic scene (500 Adam steps, ``tests/model``): nearest
upsampling left the validity AP at ≈ 0.6 (blocks of 2³ voxels share their coarse features, and
valid regions are a voxel or two thick), trilinear reached ≈ 1.0; without GroupNorm the approach
axis of ``bingham2d`` stayed at ≈ 20° median error after 300 steps, with it ≈ 11° (6° after 500).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import torch
import torch.nn.functional as F
from torch import nn
from torch.utils.flop_counter import FlopCounterMode

from symgrasp import rotation
from symgrasp.config import NetworkConfig
from symgrasp.workspace import RESOLUTION

Tensor = torch.Tensor

VALID_PRIOR = 0.01
"""Initial validity probability of every voxel."""

BINGHAM_BOUND = 20.0
"""Bingham parameter channels pass through ``BINGHAM_BOUND · tanh(a / BINGHAM_BOUND)``."""

MEMORY_FORMAT = torch.channels_last_3d
"""Layout of the weights and activations. oneDNN's 3D convolutions run channels-last natively:
in the default layout every convolution reorders its input and output, and a CPU training step
took 1.6× as long (`benchmarks/model.py`, docs/reports/training-speed.md)."""


class GraspOutput(NamedTuple):
    """Per-voxel outputs of `GraspNet` for a batch of B volumes of D × H × W voxels."""

    score: Tensor
    """``[B, D, H, W]`` gravity-rejection score (label units)."""
    validity: Tensor
    """``[B, D, H, W]`` grasp-validity logit (sigmoid → probability)."""
    rotation: Tensor
    """``[B, C, D, H, W]`` the representation's channels."""


class PointwiseConv3d(nn.Conv3d):
    """A 1×1×1 `nn.Conv3d` (the same parameters and state dict) computed as a matrix product
    over the channels of a channels-last ``[B, C, D, H, W]`` input; the output is channels-last.

    For a 1×1×1 kernel at batch < 16 on one CPU thread PyTorch's eager convolution leaves
    oneDNN for its reference kernel (``slow_conv3d``: an unfold and layout copies each way),
    which is how a training step runs where jobs share a machine one core each. As a product
    over channels, a step of 16 real scenes in micro-batches of 2 took 1.65 s against 2.01
    (one thread beside another training job, `benchmarks/model.py`,
    docs/reports/training-speed.md). Inference
    graphs (`symgrasp.model.torchscript.optimize`) run it as oneDNN's convolution, like the
    others.
    """

    def forward(self, x: Tensor) -> Tensor:
        weight = self.weight.view(self.out_channels, self.in_channels)
        return F.linear(x.permute(0, 2, 3, 4, 1), weight, self.bias).permute(0, 4, 1, 2, 3)


def _conv(c_in: int, c_out: int, kernel: int, stride: int = 1) -> nn.Conv3d:
    if kernel == 1 and stride == 1:
        return PointwiseConv3d(c_in, c_out, 1)
    return nn.Conv3d(c_in, c_out, kernel, stride=stride, padding=kernel // 2)


class GraspNet(nn.Module):
    """TSDF ``[B, 1, D, H, W]`` (D, H, W divisible by 8) → `GraspOutput`."""

    def __init__(self, config: NetworkConfig | None = None) -> None:
        super().__init__()
        self.config = config or NetworkConfig()
        w0, w1, w2, w3 = self.config.widths
        self.representation = rotation.get(self.config.representation)
        self.enc0 = _conv(1, w0, 3)
        self.enc1 = _conv(w0, w1, 3, stride=2)
        self.enc2 = _conv(w1, w2, 3, stride=2)
        self.enc3 = _conv(w2, w3, 3, stride=2)
        self.middle = _conv(w3, w3, 3)
        # Channels are reduced before upsampling, where it is 8× cheaper.
        self.reduce2, self.dec2 = _conv(w3, w2, 1), _conv(w2, w2, 3)
        self.reduce1, self.dec1 = _conv(w2, w1, 1), _conv(w1, w1, 3)
        self.dec0 = _conv(w1 + w0, self.config.features, 1)
        self.norm0, self.norm1, self.norm2, self.norm3 = (_norm(w) for w in (w0, w1, w2, w3))
        self.norm_middle, self.norm_dec2, self.norm_dec1 = _norm(w3), _norm(w2), _norm(w1)
        self.score_head = _conv(self.config.features, 1, 1)
        self.validity_head = _conv(self.config.features, 1, 1)
        self.rotation_head = _conv(self.config.features, self.representation.channels, 1)
        # Valid voxels are rare (≈ 1 %): starting at that prior keeps the first steps from being
        # spent on the bias (the prior initialisation of Lin et al. 2017, "Focal Loss").
        nn.init.constant_(self.validity_head.bias, math.log(VALID_PRIOR / (1 - VALID_PRIOR)))
        self.to(memory_format=MEMORY_FORMAT)  # loading a state dict keeps it (copy_)

    def features(self, tsdf: Tensor) -> Tensor:
        """``[B, 1, D, H, W]`` → the ``[B, features, D, H, W]`` feature volume."""
        if tsdf.ndim != 5 or tsdf.shape[1] != 1 or any(s % 8 for s in tsdf.shape[2:]):
            raise ValueError(
                "tsdf must be [B, 1, D, H, W] with D, H, W divisible by 8, "
                f"got shape {tuple(tsdf.shape)}"
            )
        e0 = F.relu(self.norm0(self.enc0(tsdf.contiguous(memory_format=MEMORY_FORMAT))))
        e1 = F.relu(self.norm1(self.enc1(e0)))
        e2 = F.relu(self.norm2(self.enc2(e1)))
        x = F.relu(self.norm3(self.enc3(e2)))
        x = F.relu(self.norm_middle(self.middle(x)))
        x = F.relu(self.norm_dec2(self.dec2(_up(self.reduce2(x)) + e2)))
        x = F.relu(self.norm_dec1(self.dec1(_up(self.reduce1(x)) + e1)))
        return F.relu(self.dec0(torch.cat([_up(x), e0], dim=1)))

    def forward(self, tsdf: Tensor) -> GraspOutput:
        x = self.features(tsdf)
        return GraspOutput(  # in the default layout, which callers index and view
            score=self.score_head(x).squeeze(1).contiguous(),
            validity=self.validity_head(x).squeeze(1).contiguous(),
            rotation=self._bound(self.rotation_head(x)).contiguous(),
        )

    def _bound(self, rotation: Tensor) -> Tensor:
        """Soft-clip the representation's `bounded_channels`, the Bingham parameters
        (identity for other representations).

        A voxel whose targets share one closing axis has a Bingham NLL unbounded below: the
        loss keeps rewarding a sharper A, the head's weights and the shared features grow
        without end and the other heads diverge (observed on noise-free labels). Entries
        of A up to ±`BINGHAM_BOUND` = 20 still allow eigenvalue gaps of ≈ 40, a spread of a few
        degrees; the paper's BNLL of ±0.5 means gaps of 5–10 (docs/model.md).
        """
        channels = self.representation.bounded_channels
        if channels is None:
            return rotation
        a = rotation[:, channels]
        bounded = BINGHAM_BOUND * torch.tanh(a / BINGHAM_BOUND)
        return torch.cat([bounded, rotation[:, channels.stop :]], dim=1)


def _norm(channels: int) -> nn.GroupNorm:
    return nn.GroupNorm(min(4, channels), channels)


def _up(x: Tensor) -> Tensor:
    return F.interpolate(x, scale_factor=2, mode="trilinear", align_corners=False)


def count_parameters(model: nn.Module) -> int:
    """Number of trainable parameters."""
    return sum(p.numel() for p in model.parameters() if p.requires_grad)


def count_flops(model: nn.Module, resolution: int = RESOLUTION) -> int:
    """Floating-point operations of one forward pass on one ``resolution³`` volume.

    Counted by `torch.utils.flop_counter.FlopCounterMode`: a multiply–add is 2 FLOP;
    elementwise operations (ReLU, sums, upsampling) are not counted.
    """
    parameter = next(model.parameters())
    tsdf = torch.zeros(1, 1, resolution, resolution, resolution, device=parameter.device)
    counter = FlopCounterMode(display=False)
    with counter, torch.no_grad():
        model(tsdf)
    return counter.get_total_flops()
