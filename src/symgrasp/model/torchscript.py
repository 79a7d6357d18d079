"""`GraspNet` as a TorchScript graph: faster inference here, and a file other stacks can run.

`trace` records the network's forward pass on one ``[1, 1, 40, 40, 40]`` TSDF and freezes it
(weights inlined as constants, `torch.jit.freeze`). `optimize` makes the detector's faster
graph (``GraspDetector(optimize=True)``). On the CPU, eager PyTorch runs most of these batch-1
3D convolutions with its reference kernel (``slow_conv3d``); the optimised graph is a copy of
the network whose every convolution calls oneDNN's (`torch.mkldnn_convolution`) on
channels-last tensors, traced and frozen: on the 2-core CPU its forward pass takes ≈ 0.4× the
eager time, where `torch.jit.optimize_for_inference` reached ≈ 0.6× (it keeps oneDNN's own
tensor layout between convolutions and converts back and forth around every GroupNorm, and
upsamples in the default layout; `benchmarks/detect.py`, docs/reports/latency.md). Off the CPU the
frozen graph is fused by `torch.jit.optimize_for_inference`. Outputs differ from eager by float
rounding only (≈ 1e-5 here; tests allow 1e-4).

`save_torchscript` writes the frozen graph of the network itself (not the oneDNN copy, so that
it runs on any device) with the facts a reader needs beside it (``symgrasp.json``:
representation, channel layout, gripper, workspace, thresholds): a file ``torch.jit.load``
(Python) or ``torch::jit::load`` (C++, LibTorch) runs without symgrasp; a reader may call
`torch.jit.optimize_for_inference` on the loaded module. docs/detect.md, "Exported model",
shows the decoding a reader does after the network.

PyTorch 2.13 marks TorchScript deprecated (for `torch.compile` and `torch.export`), and this
module silences those warnings: on the 2-core CPU `torch.compile` took 31 s to compile and ran
the forward pass in 20.9 ms against `optimize_for_inference`'s graph's 10.1 (medians, one process, load 1.2),
and a file `torch.export` writes runs in C++ only once compiled by AOTInductor for one machine.
LibTorch still loads TorchScript.
"""

from __future__ import annotations

import contextlib
import copy
import json
import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import torch
from torch import nn

from symgrasp.atomic import write_atomic
from symgrasp.model.network import GraspNet, GraspOutput
from symgrasp.workspace import RESOLUTION

Tensor = torch.Tensor

METADATA = "symgrasp.json"
"""The name of the metadata entry inside an exported file (`torch.jit.load`'s
``_extra_files``)."""


def trace(model: GraspNet) -> torch.jit.ScriptModule:
    """``model`` (in eval mode) traced on one 40³ TSDF on its own device and frozen: a module
    ``[B, 1, 40, 40, 40]`` TSDF → (score ``[B, 40, 40, 40]``, validity logit ``[B, 40, 40, 40]``,
    rotation channels ``[B, C, 40, 40, 40]``), `GraspOutput`'s fields as a tuple. Input shapes
    are not checked inside the graph: the caller checks them (`GraspDetector` does)."""
    if model.training:
        raise ValueError("model must be in eval mode (model.eval()) before it is traced")
    device = next(model.parameters()).device
    example = torch.zeros(1, 1, RESOLUTION, RESOLUTION, RESOLUTION, device=device)
    # The tracer warns of `GraspNet`'s input-shape check, which a fixed-shape trace reads once.
    with torch.no_grad(), _quiet(torch.jit.TracerWarning):
        return torch.jit.freeze(torch.jit.trace(model, example))


def optimize(model: GraspNet) -> torch.jit.ScriptModule:
    """``model`` (in eval mode) as the fastest inference graph for its device (module doc):
    the same inputs and outputs as `trace`'s."""
    device = next(model.parameters()).device
    if device.type != "cpu" or not torch.backends.mkldnn.is_available():
        with _quiet():
            return torch.jit.optimize_for_inference(trace(model))
    inference = copy.deepcopy(model)
    for module in list(inference.modules()):
        for name, child in list(module.named_children()):
            if isinstance(child, nn.Conv3d):
                setattr(module, name, _OneDNNConv3d(child))
            elif isinstance(child, nn.GroupNorm):
                setattr(module, name, ChannelsLastGroupNorm(child))
    return trace(inference)


class _OneDNNConv3d(nn.Module):
    """A `nn.Conv3d`'s weights run by oneDNN on a channels-last copy of the input; the output is
    channels-last too, which the trilinear upsampling after some of them needs to be fast (≈ 4×
    the default layout's speed here)."""

    def __init__(self, conv: nn.Conv3d) -> None:
        super().__init__()
        self.weight, self.bias = conv.weight, conv.bias
        self.padding, self.stride = conv.padding, conv.stride
        self.dilation, self.groups = conv.dilation, conv.groups

    def forward(self, x: Tensor) -> Tensor:
        x = x.contiguous(memory_format=torch.channels_last_3d)
        return torch.mkldnn_convolution(
            x, self.weight, self.bias, self.padding, self.stride, self.dilation, self.groups
        )


class ChannelsLastGroupNorm(nn.Module):
    """A `nn.GroupNorm`'s weights applied to a channels-last ``[B, C, D, H, W]`` tensor, with
    statistics as exact as the default layout's kernel gives.

    PyTorch's CPU GroupNorm on channels-last tensors accumulates its statistics in one pass and
    loses about three digits where a group's mean is large against its spread (≈ 2e-3 from a
    float64 reference at mean 50, SD 3, against 2.5e-6 in the default layout;
    tests/model/test_model_torchscript.py), enough to move the network's rotation outputs by
    1e-3. Here each group's mean and variance are taken in two passes, float32 sums over W
    only (≤ 40 terms) and float64 over the rest, then ``(x − mean) · rstd · γ + β``.
    """

    def __init__(self, norm: nn.GroupNorm) -> None:
        super().__init__()
        self.groups, self.eps = norm.num_groups, norm.eps
        self.weight, self.bias = norm.weight, norm.bias

    def forward(self, x: Tensor) -> Tensor:
        b, c = x.shape[:2]
        y = x.permute(0, 2, 3, 4, 1)  # [B, D, H, W, C]: contiguous for a channels-last x
        n = y.numel() // (b * self.groups)
        mean = self._group_sums(y) / n
        d = y - self._per_channel(mean, c).float()
        rstd = torch.rsqrt(self._group_sums(d * d) / n + self.eps)
        scale = (self._per_channel(rstd, c) * self.weight.double()).float()
        return torch.addcmul(self.bias, d, scale).permute(0, 4, 1, 2, 3)

    def _group_sums(self, y: Tensor) -> Tensor:
        """``[B, D, H, W, C]`` → each group's sum ``[B, groups]`` in float64."""
        per_channel = y.sum(3).double().sum((1, 2))
        return per_channel.view(y.shape[0], self.groups, -1).sum(-1)

    def _per_channel(self, per_group: Tensor, channels: int) -> Tensor:
        """``[B, groups]`` → ``[B, 1, 1, 1, C]``, each channel its group's value."""
        repeated = per_group.repeat_interleave(channels // self.groups, dim=1)
        return repeated.view(per_group.shape[0], 1, 1, 1, channels)


def forward(module: torch.jit.ScriptModule, tsdf: Tensor) -> GraspOutput:
    """Run a traced graph on ``tsdf`` ``[B, 1, 40, 40, 40]``: the same `GraspOutput` as
    ``GraspNet.forward``."""
    with torch.no_grad():
        return GraspOutput(*module(tsdf))


def save_torchscript(model: GraspNet, path: str | Path, metadata: dict[str, Any]) -> Path:
    """Write ``model`` (moved to the CPU) traced and frozen (`trace`) to ``path``, atomically,
    with ``metadata`` (JSON-serialisable) as its `METADATA` entry."""
    if Path(path).is_dir():
        raise ValueError(f"out {path} is a folder; give the .pt file to write")
    module = trace(model.cpu().eval())
    extra = {METADATA: json.dumps(metadata, indent=1)}
    with _quiet():
        return write_atomic(path, lambda file: torch.jit.save(module, file, _extra_files=extra))


@contextlib.contextmanager
def _quiet(*also: type[Warning]) -> Iterator[None]:
    """Silence TorchScript's deprecation warnings (see the module's docstring) and ``also``."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", category=DeprecationWarning, module=r"torch\.jit")
        for category in also:
            warnings.simplefilter("ignore", category)
        yield
