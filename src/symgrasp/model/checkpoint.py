"""Checkpoints: the weights with everything needed to trust and rebuild them.

A checkpoint is a ``torch.save`` dict holding ``format``, ``symgrasp_version``,
``representation``, ``gripper`` (the spec's `GripperSpec.to_dict`; a built-in's name in older
checkpoints), ``object_set``, ``dataset_hash``, ``network`` (the
`NetworkConfig` as a dict), ``config`` (`TrainConfig.record`: flat, read back by
`TrainConfig.from_record`), ``epoch`` (epochs done),
``history`` (one metrics dict per epoch), ``best_val_loss``, ``model`` and ``optimizer`` state.
A run trained with ``ema`` holds the weight average in ``model`` (what `load_model` loads) and the
trained weights in ``model_raw`` (only to resume). It loads with ``weights_only=True``: plain data
and tensors only, after the CRC-32 of every entry of its zip archive is checked (``torch.load``
does not: a flipped byte among the weights would load as another, often finite, number), and
its weights must be finite.
"""

from __future__ import annotations

import zipfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import torch

from symgrasp.atomic import write_atomic
from symgrasp.config import NetworkConfig
from symgrasp.model.network import GraspNet
from symgrasp.sim.grippers import GripperSpec, get_gripper

CHECKPOINT_FORMAT = 1

WEIGHTS = ("model", "model_raw")
"""The entries of a checkpoint that hold a network's state dict (`load_checkpoint` checks that
their floating tensors are finite)."""

MODEL_KEYS = ("representation", "network", "model")
"""The entries a checkpoint needs to rebuild its network (`load_model`): `load_checkpoint`
refuses one without them."""

NUMPY_FLOATS = (torch.float16, torch.float32, torch.float64)
"""The floating dtypes numpy has (not bfloat16)."""


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
        ValueError: the file is not a symgrasp checkpoint of this format, lacks an entry of
            `MODEL_KEYS`, or it was trained for another rotation representation than
            ``representation`` (when given).
    """
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"checkpoint: no file at {path}")
    unreadable = f"checkpoint: {path} is not a readable symgrasp checkpoint"
    try:
        corrupted = _failing_entry(path)
        state = (
            None if corrupted else torch.load(path, map_location=map_location, weights_only=True)
        )
    except Exception as err:  # damaged bytes raise many types (UnpicklingError, RuntimeError,
        # BadZipFile, UnicodeDecodeError, ...): to the user each means the same
        reason = (str(err).strip().splitlines() or [""])[0][:200]
        raise ValueError(
            f"{unreadable} (truncated or corrupted; {type(err).__name__}: {reason})"
        ) from None
    if corrupted:
        raise ValueError(
            f"{unreadable}: its bytes are corrupted (the entry {corrupted} fails its CRC-32 check)"
        )
    if not isinstance(state, dict) or state.get("format") != CHECKPOINT_FORMAT:
        raise ValueError(
            f"checkpoint: {path} is not a symgrasp checkpoint of format {CHECKPOINT_FORMAT}"
        )
    missing = [key for key in MODEL_KEYS if key not in state]
    if missing:
        raise ValueError(
            f"checkpoint: {path} lacks {', '.join(map(repr, missing))}: a checkpoint holds "
            f"{', '.join(MODEL_KEYS)} to rebuild its network"
        )
    if representation is not None and state["representation"] != representation:
        raise ValueError(
            f"checkpoint: {path} holds a {state['representation']!r} model, "
            f"but the representation {representation!r} was asked for"
        )
    for weights in WEIGHTS:
        for name, tensor in state.get(weights, {}).items():
            if tensor.is_floating_point() and not _finite(tensor):
                bad = int((~torch.isfinite(tensor)).sum())
                raise ValueError(
                    f"checkpoint: {path} holds non-finite weights: {weights}[{name!r}] has {bad} "
                    f"NaN or infinite values of {tensor.numel()} (a diverged run? take an "
                    "earlier checkpoint)"
                )
    return state


def _finite(tensor: torch.Tensor) -> bool:
    """Whether every entry of a floating tensor is finite: by numpy where it can, since on a
    model's few dozen small tensors torch's reductions cost 4× more and, on a busy CPU, now and
    then tens of milliseconds waiting for their worker threads."""
    if tensor.device.type == "cpu" and tensor.dtype in NUMPY_FLOATS:
        return bool(np.isfinite(tensor.numpy()).all())
    return bool(torch.isfinite(tensor).all())


def _failing_entry(path: Path) -> str | None:
    """The first entry of the checkpoint's zip archive whose bytes fail its CRC-32, if any
    (None for a file that is no zip archive: ``torch.load`` judges it)."""
    if not zipfile.is_zipfile(path):
        return None
    with zipfile.ZipFile(path) as archive:
        return archive.testzip()


def load_model(
    path: str | Path,
    representation: str | None = None,
    map_location: str | torch.device = "cpu",
) -> tuple[GraspNet, dict[str, Any]]:
    """The trained `GraspNet` at ``path`` (in eval mode) and its checkpoint dict. ValueError as
    `load_checkpoint`, and naming the file when its ``network`` is no `NetworkConfig` or its
    weights do not fit the network it describes (a tensor of another shape, one missing or
    unknown: a hand-edited file, another version's)."""
    state = load_checkpoint(path, representation, map_location)
    try:
        model = GraspNet(NetworkConfig(**state["network"]))
    except (TypeError, ValueError) as error:
        raise ValueError(
            f"checkpoint: {path}'s network is not a valid NetworkConfig: {error}"
        ) from None
    expected = model.state_dict()
    weights = state["model"]
    for name, tensor in weights.items():
        if name in expected and tuple(tensor.shape) != tuple(expected[name].shape):
            raise ValueError(
                f"checkpoint: {path}'s weights do not fit its network: model[{name!r}] has shape "
                f"{tuple(tensor.shape)}, the network's is {tuple(expected[name].shape)}"
            )
    missing, unknown = sorted(set(expected) - set(weights)), sorted(set(weights) - set(expected))
    if missing or unknown:
        raise ValueError(
            f"checkpoint: {path}'s weights do not fit its network: "
            + "; ".join(
                f"{what} {', '.join(map(repr, names[:3]))}{' …' if len(names) > 3 else ''}"
                for what, names in (("missing", missing), ("unknown", unknown))
                if names
            )
        )
    model.load_state_dict(weights)
    return model.to(map_location).eval(), state


def trained_gripper(state: Mapping[str, Any]) -> GripperSpec:
    """The gripper the checkpoint ``state`` was trained for: its stored spec (a built-in's name
    in older checkpoints), resolved once, where the checkpoint is read."""
    return get_gripper(state["gripper"])
