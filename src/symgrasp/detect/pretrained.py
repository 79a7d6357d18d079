"""The models shipped inside the package, and how a training checkpoint becomes one.

A shipped model is a checkpoint of ``symgrasp train`` without its optimizer state (≈ 1 MB),
stored in ``symgrasp/detect/models/<name>.pt``; its model card is ``docs/models.md``.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from symgrasp.model.checkpoint import load_checkpoint, save_checkpoint, trained_gripper
from symgrasp.names import PRETRAINED
from symgrasp.sim.grippers import GripperSpec


def shipped_path(name: str) -> Path:
    """Where the shipped model ``name`` lives in the installed package."""
    return Path(str(resources.files("symgrasp.detect") / "models" / f"{name}.pt"))


def resolve_model(name_or_path: str | Path) -> Path:
    """The checkpoint file of a shipped model name or of a path; ValueError otherwise."""
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
