"""`GraspNet` as a TorchScript graph: faster inference here, and a file other stacks can run.

`trace` records the network's forward pass on one ``[1, 1, 40, 40, 40]`` TSDF and freezes it
(weights inlined as constants, `torch.jit.freeze`). `optimize` then lets PyTorch fuse it for
inference (`torch.jit.optimize_for_inference`: on the CPU, oneDNN convolutions with their
ReLUs fused and the channels-last reorders dropped): the detector's forward pass takes
≈ 0.6× the eager time on the 2-core CPU (`benchmarks/detect.py`), and its outputs differ from
eager by float rounding only (≈ 5e-6 here; tests allow 1e-4).

`save_torchscript` writes the frozen graph with the facts a reader needs beside it
(``symgrasp.json``: representation, channel layout, gripper, workspace, thresholds): a file
``torch.jit.load`` (Python) or ``torch::jit::load`` (C++, LibTorch) runs without symgrasp.
The optimised graph itself cannot be saved (PyTorch refuses to serialise its oneDNN
constants); a reader calls `torch.jit.optimize_for_inference` on the loaded module instead.
docs/detect.md, "Exported model", shows the decoding a reader does after the network.

PyTorch 2.13 marks TorchScript deprecated (for `torch.compile` and `torch.export`), and this
module silences those warnings: on the 2-core CPU `torch.compile` took 31 s to compile and ran
the forward pass in 20.9 ms against the fused graph's 10.1 (medians, one process, load 1.2), and a file `torch.export` writes runs in C++
only once compiled by AOTInductor for one machine. LibTorch still loads TorchScript.
"""

from __future__ import annotations

import contextlib
import json
import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import torch

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


def optimize(module: torch.jit.ScriptModule) -> torch.jit.ScriptModule:
    """A frozen graph (`trace`, or one `torch.jit.load` read) fused for inference."""
    with _quiet():
        return torch.jit.optimize_for_inference(module)


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
