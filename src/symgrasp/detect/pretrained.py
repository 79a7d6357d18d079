"""The models shipped inside the package, how a training checkpoint becomes one, and how a
model leaves symgrasp for another stack.

A shipped model is a checkpoint of ``symgrasp train`` without its optimizer state (≈ 1 MB),
stored in ``symgrasp/detect/models/<name>.pt``; its model card is ``docs/models.md``.
`export_torchscript` writes a model's network as a TorchScript file that LibTorch (C++) or
``torch.jit.load`` runs without symgrasp (docs/detect.md, "Exported model").
"""

from __future__ import annotations

import json
from importlib import resources
from pathlib import Path
from typing import Any

from symgrasp import __version__
from symgrasp.config import DEFAULT_VALIDITY
from symgrasp.digest import file_sha256
from symgrasp.model.checkpoint import (
    load_checkpoint,
    load_model,
    save_checkpoint,
    trained_gripper,
)
from symgrasp.model.ranking import DEFAULT_NMS_RADIUS
from symgrasp.model.torchscript import save_torchscript
from symgrasp.names import PRETRAINED
from symgrasp.perception.tsdf import TRUNCATION_VOXELS
from symgrasp.sim.grippers import GripperSpec
from symgrasp.workspace import RESOLUTION, VOXEL_SIZE, WORKSPACE_SIZE

TORCHSCRIPT_FORMAT = "symgrasp-torchscript-1"
"""The ``format`` of an exported file's metadata; a change of its meaning changes the name."""


OPERATING_POINT_KEYS = ("validity_threshold", "confidence_threshold", "validity_floor", "fallbacks")
"""The `GraspDetector` options a model card's operating point sets."""


def shipped_operating_point(name_or_path: str | Path) -> dict[str, Any]:
    """The operating point stored in the model card of the shipped model ``name_or_path``
    (``symgrasp/detect/models/operating_points.json``: the `OPERATING_POINT_KEYS` chosen for it
    on training-object rounds, docs/models.md), as `GraspDetector` keyword arguments; ``{}``
    for a checkpoint file or a shipped model whose operating point has not been chosen (the
    library's defaults apply)."""
    if str(name_or_path) not in PRETRAINED:
        return {}
    point = _read_operating_points().get(str(name_or_path), {})
    return {key: point[key] for key in OPERATING_POINT_KEYS if key in point}


def _read_operating_points() -> dict[str, dict[str, Any]]:
    """The shipped models' operating points by name: the chosen options and, under
    ``"chosen"``, how they were chosen (rounds, objects, command, result file)."""
    return json.loads((_models_folder() / "operating_points.json").read_text())


def _models_folder() -> Path:
    return Path(str(resources.files("symgrasp.detect") / "models"))


def shipped_path(name: str) -> Path:
    """Where the shipped model ``name`` lives in the installed package."""
    return _models_folder() / f"{name}.pt"


def resolve_model(name_or_path: str | Path) -> Path:
    """The checkpoint file of a shipped model name or of a path; ValueError otherwise (TypeError
    for neither a string nor a path)."""
    if not isinstance(name_or_path, (str, Path)):
        raise TypeError(
            f"model must be a shipped model's name or a checkpoint path, got {name_or_path!r}"
        )
    path = Path(name_or_path)
    if path.is_file():
        return path
    if str(name_or_path) in PRETRAINED:
        shipped = shipped_path(str(name_or_path))
        if not shipped.is_file():
            raise ValueError(
                f"model {name_or_path!r} is not in this installation ({shipped} is missing)"
            )
        return shipped
    raise ValueError(
        f"model {str(name_or_path)!r} is neither a checkpoint file nor a shipped model; "
        f"shipped: {', '.join(PRETRAINED)}"
    )


def trained_for(name_or_path: str | Path) -> tuple[str, GripperSpec]:
    """The rotation representation and the gripper of the model ``name_or_path`` (as
    `resolve_model` takes it), read from its checkpoint without building its network."""
    state = load_checkpoint(resolve_model(name_or_path))
    return state["representation"], trained_gripper(state)


def export_model(checkpoint: str | Path, out: str | Path) -> Path:
    """Write ``checkpoint`` without its optimizer state (nor, for a run with a weight average,
    its trained weights ``model_raw``: ``model`` is the average) to ``out`` (what gets
    shipped)."""
    if Path(out).is_dir():
        raise ValueError(f"out {out} is a folder; give the .pt file to write")
    state = load_checkpoint(checkpoint)
    state.pop("optimizer", None)
    state.pop("model_raw", None)
    state.pop("format", None)
    save_checkpoint(out, state)
    return Path(out)


def export_torchscript(name_or_path: str | Path, out: str | Path) -> Path:
    """Write the network of model ``name_or_path`` (as `resolve_model` takes it) to ``out`` as
    a frozen TorchScript graph, TSDF ``[B, 1, 40, 40, 40]`` → (score, validity logit, rotation
    channels), with the facts its reader needs as metadata (`symgrasp.model.torchscript`): the
    input grid, the representation, the gripper, the detector's default thresholds."""
    path = resolve_model(name_or_path)
    model, state = load_model(path, map_location="cpu")
    representation = model.representation
    metadata = {
        "format": TORCHSCRIPT_FORMAT,
        "model": str(name_or_path),
        "checkpoint_sha256": file_sha256(path),
        "symgrasp_version": __version__,
        "input": {
            "shape": [1, 1, RESOLUTION, RESOLUTION, RESOLUTION],
            "what": "TSDF in [-1, 1] (1: free or unseen, < 0 behind the surface), the signed "
            "depth difference along the optical axis over the truncation, averaged over views",
            "resolution": RESOLUTION,
            "workspace_size_m": WORKSPACE_SIZE,
            "voxel_size_m": VOXEL_SIZE,
            "truncation_voxels": TRUNCATION_VOXELS,
            "voxel_centre": "origin + (index + 0.5) * voxel_size, index (i, j, k) along world "
            "(x, y, z); the table top 0.05 m above the origin",
        },
        "outputs": [
            "score [B, 40, 40, 40]: gravity-rejection score",
            "validity [B, 40, 40, 40]: logit (sigmoid gives the probability)",
            f"rotation [B, {representation.channels}, 40, 40, 40]: the representation's channels",
        ],
        "representation": representation.name,
        "channels": representation.channels,
        "grasp_frame": "R = [e_x e_y e_z]: approach, e_z x e_x, closing axis; the TCP at the "
        "voxel centre",
        "gripper": trained_gripper(state).to_dict(),
        "defaults": {
            "validity_threshold": DEFAULT_VALIDITY,
            "confidence_threshold": representation.default_confidence,
            "nms_radius_voxels": DEFAULT_NMS_RADIUS,
        },
        "decoding": "docs/detect.md, 'Exported model'",
    }
    return save_torchscript(model, out, metadata)
