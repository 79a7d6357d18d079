"""Rotation distribution (Sec. "Analysis of Rotation Distribution", Fig. 4): closing axes
sampled from a Bingham detector over the box and a flat cylinder.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import torch
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure

from symgrasp.analysis.continuity import reduce_or_none
from symgrasp.analysis.files import save_figure, write_json
from symgrasp.analysis.scenes import (
    ARROW_LENGTH,
    FLAT_CYLINDER,
    LONG_BOX,
    SLICE_HEIGHT,
    FieldSlice,
    Placed,
    check_validity,
    choose_layer,
    cut_layer,
    draw_field,
    predict,
    render_depth,
    voxel_centres_xy,
)
from symgrasp.config import DEFAULT_VALIDITY
from symgrasp.detect import GraspDetector
from symgrasp.folders import PICTURES, writes_folder
from symgrasp.workspace import VOXEL_SIZE


@dataclass(frozen=True)
class SampledAxes:
    """Closing axes drawn at the valid voxels of a layer (M voxels, n samples each)."""

    xy: np.ndarray
    """``[M, 2]`` voxel centres [m]."""
    samples: np.ndarray
    """``[M, n, 3]`` e_z drawn from B(A), after Gram–Schmidt against e_x."""
    mode: np.ndarray
    """``[M, 3]`` the decoded e_z (the mode)."""
    confidence: np.ndarray
    """``[M]`` (λ₃ − λ₂) + (λ₃ − λ₁)."""

    def spread_deg(self) -> np.ndarray:
        """``[M]`` mean angle between the samples and the mode, up to sign [deg]: 0 for a
        point mass, 45° for e_z uniform about a fixed approach axis."""
        cosine = np.abs(np.einsum("mni,mi->mn", self.samples, self.mode))
        return np.degrees(np.arccos(np.clip(cosine, 0.0, 1.0))).mean(-1)


def sample_axes(field: FieldSlice, valid: np.ndarray, n: int, seed: int) -> SampledAxes:
    """``n`` e_z per valid voxel from the predicted distribution (the paper's third decoding
    mode, Sec. 3.3), seeded."""
    representation = field.representation
    if not representation.has_distribution:
        raise ValueError(
            f"--model: a {representation.name!r} model predicts one rotation per voxel; "
            "the distribution figure needs a Bingham model"
        )
    pred = field.rotation[torch.as_tensor(valid)]
    decoded = representation.decode(pred)
    drawn = representation.sample(pred, n, torch.Generator().manual_seed(seed))
    return SampledAxes(
        voxel_centres_xy()[valid],
        drawn[..., 2].numpy(),
        decoded.rotation[..., 2].numpy(),
        decoded.confidence.numpy(),
    )


def object_statistics(axes: SampledAxes, objects: Sequence[Placed]) -> dict[str, Any]:
    """Per object: its voxels (the valid voxels whose nearest footprint is the object's, at
    most one voxel away), their mean confidence and mean `SampledAxes.spread_deg`."""
    distance = np.stack([o.footprint_distance(axes.xy) for o in objects], axis=-1)  # [M, O]
    nearest = distance.argmin(-1)
    spread = axes.spread_deg()
    stats = {}
    for index, o in enumerate(objects):
        mine = (nearest == index) & (distance[:, index] <= VOXEL_SIZE)
        stats[o.name] = {
            "voxels": int(mine.sum()),
            "mean_confidence": reduce_or_none(np.mean, axes.confidence[mine]),
            "mean_spread_deg": reduce_or_none(np.mean, spread[mine]),
        }
    return stats


def plot_distribution(
    field: FieldSlice, valid: np.ndarray, axes: SampledAxes, objects: Sequence[Placed]
) -> Figure:
    """Fig. 4: the score of the valid voxels in grey and every sampled e_z
    as a segment through its voxel centre, projected to x–y, coloured by confidence."""
    figure, ax = plt.subplots(figsize=(7.5, 6))
    draw_field(ax, field, valid, objects, "Greys")
    half = ARROW_LENGTH / 2 * axes.samples[..., :2]  # [M, n, 2]
    centre = axes.xy[:, None]
    segments = np.stack([centre - half, centre + half], axis=-2).reshape(-1, 2, 2)
    lines = LineCollection(segments, cmap="plasma", linewidths=0.6, alpha=0.6)
    lines.set_array(np.repeat(axes.confidence, axes.samples.shape[1]))
    ax.add_collection(lines)
    figure.colorbar(lines, ax=ax, label="confidence (λ₃−λ₂)+(λ₃−λ₁)", shrink=0.8)
    n = axes.samples.shape[1]
    z_mm = (field.layer + 0.5) * VOXEL_SIZE * 1e3
    ax.set_title(f"{field.representation.name}: {n} samples of e_z per voxel at z = {z_mm:.1f} mm")
    figure.tight_layout()
    return figure


@writes_folder(PICTURES)
def distribution_figure(
    model: str | Path,
    out: str | Path,
    samples: int = 30,
    height: float | None = SLICE_HEIGHT,
    validity: float = DEFAULT_VALIDITY,
    seed: int = 0,
    command: str | None = None,
) -> dict[str, Path]:
    """Write ``rotation_distribution.png`` and ``.json`` (per object: voxels, mean
    confidence, mean spread) into ``out`` for a Bingham ``model`` on the box and the flat
    cylinder of Sec. 4.2, in the layer at ``height`` (None: `busiest_layer`); returns their
    paths by suffix."""
    if samples < 1:
        raise ValueError(f"--samples must be ≥ 1, got {samples}")
    check_validity(validity)
    objects = (LONG_BOX, FLAT_CYLINDER)
    detector = GraspDetector.from_pretrained(model, device="cpu")
    volumes = predict(detector, render_depth(objects))
    layer = choose_layer(height, [volumes], validity)
    field = cut_layer(volumes, detector.representation, layer)
    valid = field.validity >= validity
    axes = sample_axes(field, valid, samples, seed)
    record = {
        "command": command,
        "model": str(model),
        "representation": field.representation.name,
        "height": height,
        "layer": layer,
        "layer_centre_m": (layer + 0.5) * VOXEL_SIZE,
        "validity_threshold": validity,
        "samples": samples,
        "seed": seed,
        "valid_voxels": int(valid.sum()),
        "objects": object_statistics(axes, objects),
    }
    figure = plot_distribution(field, valid, axes, objects)
    return {
        "json": write_json(Path(out) / "rotation_distribution.json", record),
        "png": save_figure(figure, Path(out) / "rotation_distribution.png"),
    }
