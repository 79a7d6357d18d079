"""Checkpoints: the weights with everything needed to trust and rebuild them.

A checkpoint is a ``torch.save`` dict holding ``format``, ``symgrasp_version``,
``representation``, ``gripper`` (the spec's `GripperSpec.to_dict`; a built-in's name in older
checkpoints), ``object_set``, ``dataset_hash``, ``network`` (the
`NetworkConfig` as a dict), ``config`` (`TrainConfig.record`: flat, read back by
`TrainConfig.from_record`), ``epoch`` (epochs done),
``history`` (one metrics dict per epoch), ``best_val_loss``, ``model`` and ``optimizer`` state.
A run trained with ``ema`` holds the weight average in ``model`` (what `load_model` loads) and the
trained weights in ``model_raw`` (only to resume). It loads with ``weights_only=True``: plain data
and tensors only.
"""

from __future__ import annotations

import hashlib
import pickle
import zipfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import torch

from symgrasp.atomic import write_atomic
from symgrasp.config import NetworkConfig
from symgrasp.model.network import GraspNet
from symgrasp.sim.grippers import GripperSpec, get_gripper

CHECKPOINT_FORMAT = 1


def save_checkpoint(path: str | Path, state: dict[str, Any]) -> None:
    """Write ``state`` to ``path`` atomically (a temporary file renamed over it)."""
    write_atomic(path, lambda file: torch.save({"format": CHECKPOINT_FORMAT, **state}, file))


def load_checkpoint(
    path: str | Path,
    representation: str | None = None,
    map_location: str | torch.device = "cpu",
) -> dict[str, Any]:
    """The checkpoint dict at ``path``.

    Raises:
        ValueError: the file is not a symgrasp checkpoint of this format, or it was trained
            for another rotation representation than ``representation`` (when given).
    """
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"checkpoint: no file at {path}")
    try:
        state = torch.load(path, map_location=map_location, weights_only=True)
    except (RuntimeError, EOFError, OSError, pickle.UnpicklingError, zipfile.BadZipFile) as err:
        raise ValueError(
            f"checkpoint: {path} is truncated or not a checkpoint ({type(err).__name__})"
        ) from None
    if not isinstance(state, dict) or state.get("format") != CHECKPOINT_FORMAT:
        raise ValueError(
            f"checkpoint: {path} is not a symgrasp checkpoint of format {CHECKPOINT_FORMAT}"
        )
    if representation is not None and state["representation"] != representation:
        raise ValueError(
            f"checkpoint: {path} holds a {state['representation']!r} model, "
            f"but the representation {representation!r} was asked for"
        )
    return state


def load_model(
    path: str | Path,
    representation: str | None = None,
    map_location: str | torch.device = "cpu",
) -> tuple[GraspNet, dict[str, Any]]:
    """The trained `GraspNet` at ``path`` (in eval mode) and its checkpoint dict."""
    state = load_checkpoint(path, representation, map_location)
    model = GraspNet(NetworkConfig(**state["network"]))
    model.load_state_dict(state["model"])
    return model.to(map_location).eval(), state


def trained_gripper(state: Mapping[str, Any]) -> GripperSpec:
    """The gripper the checkpoint ``state`` was trained for: its stored spec (a built-in's name
    in older checkpoints), resolved once, where the checkpoint is read."""
    return get_gripper(state["gripper"])


def file_sha256(path: str | Path) -> str:
    """The SHA-256 of a checkpoint file's bytes (hex): what tells two files of one name apart."""
    digest = hashlib.sha256()
    with open(path, "rb") as file:
        for block in iter(lambda: file.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()
