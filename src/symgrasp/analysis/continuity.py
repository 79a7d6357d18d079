"""Rotation continuity (Sec. "Analysis of Rotation Continuity", Fig. 3):
the score field and the closing axes e_z of several detectors in one horizontal voxel layer
over a long box.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from symgrasp.analysis.files import save_figure, write_json
from symgrasp.analysis.scenes import (
    ARROW_LENGTH,
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
    view_limits,
    voxel_centres_xy,
)
from symgrasp.config import DEFAULT_VALIDITY
from symgrasp.detect import GraspDetector
from symgrasp.folders import PICTURES, writes_folder
from symgrasp.workspace import VOXEL_SIZE


def closing_axes(field: FieldSlice) -> np.ndarray:
    """``[40, 40, 3]`` the decoded e_z (for ``bingham2d`` the mode of B(A), sign arbitrary)."""
    return field.representation.decode(field.rotation).rotation[..., 2].numpy()


def continuity_statistics(
    e_z: np.ndarray, valid: np.ndarray, sign_invariant: bool
) -> dict[str, Any]:
    """How smoothly e_z ``[40, 40, 3]`` varies over the ``valid [40, 40]`` voxels of a layer.

    Over pairs of 4-neighbouring valid voxels, the angle between their e_z: up to sign
    (arccos |e·e'|) when ``sign_invariant`` (``bingham2d``, where ±e_z are one parameter set),
    with sign (arccos e·e') otherwise, where a 180° jump is a real change of the output. Reports
    its median and 90th percentile [deg] and the fraction of pairs above 90° (flips), and the
    median angle between e_z and the ±y line [deg], the closing axis the long box needs
    (mode averaging shows up there). Statistics of no pair or voxel are None.
    """
    pairs = [
        (e_z[:-1][valid[:-1] & valid[1:]], e_z[1:][valid[:-1] & valid[1:]]),
        (e_z[:, :-1][valid[:, :-1] & valid[:, 1:]], e_z[:, 1:][valid[:, :-1] & valid[:, 1:]]),
    ]
    cosine = np.concatenate([(a * b).sum(-1) for a, b in pairs])
    if sign_invariant:
        cosine = np.abs(cosine)
    angles = np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0)))
    off_y = np.degrees(np.arccos(np.clip(np.abs(e_z[valid][:, 1]), 0.0, 1.0)))
    return {
        "valid_voxels": int(valid.sum()),
        "neighbour_pairs": len(angles),
        "sign_invariant": sign_invariant,
        "neighbour_angle_deg_median": reduce_or_none(np.median, angles),
        "neighbour_angle_deg_p90": reduce_or_none(lambda a: np.percentile(a, 90), angles),
        "neighbour_flip_fraction": reduce_or_none(lambda a: np.mean(a > 90), angles),
        "off_y_deg_median": reduce_or_none(np.median, off_y),
    }


def reduce_or_none(reduce: Callable[[np.ndarray], Any], values: np.ndarray) -> float | None:
    """``reduce(values)`` as a float, None for no values."""
    return float(reduce(values)) if len(values) else None


def plot_continuity(
    fields: dict[str, FieldSlice], validity: float, objects: Sequence[Placed]
) -> Figure:
    """Fig. 3: one panel per model, the score of the valid voxels and
    their e_z projected to x–y, both ±e_z for ``bingham2d``."""
    lo, hi = view_limits(objects)
    height = 6 * (hi[1] - lo[1]) / (hi[0] - lo[0]) + 2
    figure, axes = plt.subplots(1, len(fields), figsize=(6 * len(fields), height), squeeze=False)
    xy = voxel_centres_xy()
    for ax, (label, field) in zip(axes[0], fields.items(), strict=True):
        valid = field.validity >= validity
        image = draw_field(ax, field, valid, objects, "viridis")
        figure.colorbar(image, ax=ax, label="gravity-rejection score", orientation="horizontal")
        e_z = closing_axes(field)[valid]
        signs = (1, -1) if field.representation.closing_axis_up_to_sign else (1,)
        for sign in signs:
            ax.quiver(
                *xy[valid].T,
                *(sign * e_z[:, :2].T),
                pivot="middle",
                angles="xy",
                scale_units="xy",
                scale=1 / ARROW_LENGTH,
                width=0.004,
            )
        ax.set_title(
            f"{label}: e_z at z = {(field.layer + 0.5) * VOXEL_SIZE * 1e3:.1f} mm", fontsize=10
        )
    figure.tight_layout()
    return figure


@writes_folder(PICTURES)
def continuity_figure(
    models: Mapping[str, str | Path],
    out: str | Path,
    height: float | None = SLICE_HEIGHT,
    validity: float = DEFAULT_VALIDITY,
    command: str | None = None,
) -> dict[str, Path]:
    """Write ``rotation_continuity.png`` and ``.json`` (per model: valid voxels and
    `continuity_statistics`) into ``out`` for ``models`` {label: checkpoint} on the long box
    of Sec. 4.1, in the layer at ``height`` (None: `busiest_layer` over all models); returns
    their paths by suffix."""
    check_validity(validity)
    objects = (LONG_BOX,)
    view = render_depth(objects)
    detectors = {
        label: GraspDetector.from_pretrained(path, device="cpu") for label, path in models.items()
    }
    outputs = {label: predict(detector, view) for label, detector in detectors.items()}
    layer = choose_layer(height, outputs.values(), validity)
    fields = {
        label: cut_layer(outputs[label], detector.representation, layer)
        for label, detector in detectors.items()
    }
    record = {
        "command": command,
        "height": height,
        "layer": layer,
        "layer_centre_m": (layer + 0.5) * VOXEL_SIZE,
        "validity_threshold": validity,
        "statistic": inspect.cleandoc(continuity_statistics.__doc__ or ""),
        "models": {
            label: {
                "path": str(models[label]),
                "representation": field.representation.name,
                **continuity_statistics(
                    closing_axes(field),
                    field.validity >= validity,
                    field.representation.closing_axis_up_to_sign,
                ),
            }
            for label, field in fields.items()
        },
    }
    figure = plot_continuity(fields, validity, objects)
    return {
        "json": write_json(Path(out) / "rotation_continuity.json", record),
        "png": save_figure(figure, Path(out) / "rotation_continuity.png"),
    }
