"""The paper's three analysis figures (Ko et al. 2024, Sec. 4.1, Sec. 4.2 and Appx. A).

- `percentile_figure`: the band angles θᵢ^(99%) of 2D Bingham distributions, approximated by
  Eq. eq:approx_percentile and measured by Monte Carlo (Appx. A, Figs. fig:sampled_2d_bingham
  and fig:projected_bingham_plot_for_percentile);
- `continuity_figure`: the score field and the closing axes e_z of several detectors in one
  horizontal voxel layer over a long box (Sec. "Analysis of Rotation Continuity",
  Fig. fig:bingham_horizontal);
- `distribution_figure`: closing axes sampled from a Bingham detector over the box and a flat
  cylinder (Sec. "Analysis of Rotation Distribution", Fig. fig:bingham_sampling).

Each writes a PNG and a JSON with the numbers and the command that made them, atomically.
The world frame is the workspace frame: the cube [0, 0.3]³ m with the table top at z = 0.05 m
(`symgrasp.sim.world`); voxel [i, j, k] of the 40³ grid has its centre at (i, j, k) + ½ voxel,
i along x. Eigenvalues are ascending, λ₁ ≤ λ₂ ≤ λ₃ = 0 (Eq. eq:sortedlambda), and ``axis`` is
0-based as in `Bingham.percentile_angle` (axis 0 ↔ λ₁ ↔ the paper's θ₁).
"""

from __future__ import annotations

import inspect
import itertools
import json
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Literal

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import torch
from matplotlib.axes import Axes
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.image import AxesImage
from matplotlib.patches import Circle, Patch, Rectangle
from tqdm import tqdm

from symgrasp.atomic import write_atomic
from symgrasp.bingham import Bingham
from symgrasp.detect import GraspDetector
from symgrasp.detect.detector import DEFAULT_VALIDITY, RESOLUTION
from symgrasp.perception import CameraIntrinsic, default_extrinsic, make_renderer
from symgrasp.rotation import Representation
from symgrasp.sim import TABLE_HEIGHT, WORKSPACE_SIZE, ObjectSpec, Part, World

PERCENTILE = 0.99
"""p of θᵢ^(p) in every table and plot (the paper's 99 %)."""

Shape = tuple[float, float, float]
"""λ = (λ₁, λ₂, λ₃), ascending."""

SHAPES: tuple[Shape, ...] = (
    (-10.0, -10.0, 0.0),
    (-50.0, -10.0, 0.0),
    (-100.0, -1.0, 0.0),
    (-200.0, -200.0, 0.0),
    (-500.0, -50.0, 0.0),
    (-1000.0, -1000.0, 0.0),
)
"""λ = (λ₁, λ₂, 0) of the percentile table: round, flat and girdle-like, loose to tight."""

PAPER_EXAMPLE: Shape = (-50.0, -10.0, 0.0)
"""λ of Fig. fig:projected_bingham_plot_for_percentile, drawn by `percentile_figure`."""

SLICE_HEIGHT = 0.057
"""World height [m] of the paper's cross-sections (z = 57 mm, 7 mm above the table). Where a
model's valid grasp centres lie higher (they depend on where the gripper's TCP is), pass
``height=None`` for the layer with the most valid voxels (`busiest_layer`)."""

VOXEL = WORKSPACE_SIZE / RESOLUTION
"""Edge of a voxel [m]."""

ARROW_LENGTH = 1.6 * VOXEL
"""Drawn length [m] of a horizontal unit e_z; a sampled e_z's segment in the distribution plot
is as long."""

VIEW_MARGIN = 0.03
"""The field plots show the objects' footprints and this much around them [m]."""

DOT_SAMPLES = 3000
"""Bingham samples drawn in the sphere plot of `percentile_figure`."""

DepthView = tuple[np.ndarray, CameraIntrinsic, np.ndarray]
"""A depth image (H, W) [m], its camera's intrinsic and ``T_world_camera`` (4, 4)."""


# -- percentiles (Appx. A) -------------------------------------------------------------------


@dataclass(frozen=True)
class PercentileRow:
    """θᵢ^(p) of B(diag(λ)) for one λ and one axis; angles in degrees."""

    lam: Shape
    axis: int
    """0-based: the band is orthogonal to the eigenvector of λ[axis]."""
    approx_deg: float
    """2 erf⁻¹(p)/√(λ₃ − λᵢ) (Eq. eq:approx_percentile)."""
    mc_mean_deg: float
    """Mean of the Monte-Carlo estimates (`Bingham.percentile_angle_mc`)."""
    mc_std_deg: float
    """Their population standard deviation over the repeats."""
    relative_difference: float
    """(approx − MC mean) / MC mean."""


def percentile_row(
    lam: Shape, axis: int, samples: int, repeats: int, seed: int, p: float = PERCENTILE
) -> PercentileRow:
    """θ_{axis+1}^(p) of B(diag(λ)) in float64 by Eq. eq:approx_percentile and by ``repeats``
    Monte-Carlo estimates of ``samples`` exact draws each, the r-th seeded ``seed + r``."""
    if samples < 1 or repeats < 1:
        raise ValueError(f"--samples and --repeats must be ≥ 1, got {samples} and {repeats}")
    distribution = Bingham(torch.diag(torch.tensor(lam, dtype=torch.float64)))
    approx = math.degrees(distribution.percentile_angle(p, axis).item())
    estimates = np.degrees(
        [
            distribution.percentile_angle_mc(
                p, axis, samples, torch.Generator().manual_seed(seed + r)
            ).item()
            for r in range(repeats)
        ]
    )
    mean = float(estimates.mean())
    return PercentileRow(lam, axis, approx, mean, float(estimates.std()), (approx - mean) / mean)


def percentile_rows(
    samples: int, repeats: int, seed: int, shapes: Sequence[Shape] = SHAPES
) -> list[PercentileRow]:
    """`percentile_row` for every λ of ``shapes`` and i = 1, 2, with a progress bar."""
    cases = list(itertools.product(shapes, (0, 1)))
    return [
        percentile_row(lam, axis, samples, repeats, seed)
        for lam, axis in tqdm(cases, desc="percentile rows", unit="row")
    ]


def percentile_markdown(rows: Iterable[PercentileRow]) -> str:
    """The rows as a Markdown table (i is the paper's 1-based index)."""
    lines = [
        f"| λ | i | approx. θᵢ^({100 * PERCENTILE:g}%) [deg] | MC mean ± std [deg] | rel. diff. |",
        "|---|---|---|---|---|",
    ]
    for row in rows:
        lam = ", ".join(f"{v:g}" for v in row.lam)
        mc = f"{row.mc_mean_deg:.2f} ± {row.mc_std_deg:.2f}"
        difference = f"{100 * row.relative_difference:+.1f} %"
        lines.append(f"| ({lam}) | {row.axis + 1} | {row.approx_deg:.2f} | {mc} | {difference} |")
    return "\n".join(lines) + "\n"


def plot_percentile_bands(rows: Sequence[PercentileRow], seed: int) -> Figure:
    """Fig. fig:projected_bingham_plot_for_percentile: `DOT_SAMPLES` samples of
    B(diag(`PAPER_EXAMPLE`)) on the sphere with the planes bounding A₁(θ₁^(99%)) (red) and
    A₂(θ₂^(99%)) (green) at the Monte-Carlo means, and the projections onto (d₁, d₃) and
    (d₂, d₃) with those planes as solid lines and the approximation as dashed lines."""
    bands = {row.axis: row for row in rows if row.lam == PAPER_EXAMPLE}
    if set(bands) != {0, 1}:
        raise ValueError(f"the rows must hold both axes of λ = {PAPER_EXAMPLE}")
    distribution = Bingham(torch.diag(torch.tensor(PAPER_EXAMPLE, dtype=torch.float64)))
    v = distribution.sample((DOT_SAMPLES,), torch.Generator().manual_seed(seed))
    c = (v @ distribution.eigenvectors).numpy()  # [N, 3]: coordinates along d₁, d₂, d₃
    colours = {0: "tab:red", 1: "tab:green"}
    figure = plt.figure(figsize=(11, 6))
    grid = figure.add_gridspec(2, 2, width_ratios=(1.6, 1))
    sphere = figure.add_subplot(grid[:, 0], projection="3d")
    _draw_sphere(sphere, c)
    for axis, row in bands.items():
        _draw_band_planes(sphere, axis, math.radians(row.mc_mean_deg), colours[axis])
        plane = figure.add_subplot(grid[axis, 1])
        _draw_projection(plane, c, row, colours[axis])
    lam = ", ".join(f"{x:g}" for x in PAPER_EXAMPLE)
    sphere.set_title(f"{DOT_SAMPLES} samples of B(diag({lam}))", fontsize=10)
    figure.tight_layout()
    return figure


def _draw_sphere(ax: Axes, c: np.ndarray) -> None:
    """A faint unit sphere and the samples ``c`` [N, 3] (eigenbasis coordinates)."""
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 40), np.linspace(0, np.pi, 20))
    ax.plot_wireframe(
        np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v), color="0.85", linewidth=0.4
    )
    ax.scatter(c[:, 0], c[:, 1], c[:, 2], s=2, alpha=0.6, color="tab:blue")
    for axis, name in zip((ax.xaxis, ax.yaxis, ax.zaxis), ("$d_1$", "$d_2$", "$d_3$"), strict=True):
        axis.set_ticks([-1, 0, 1])
        axis.set_label_text(name)
    ax.set_box_aspect((1, 1, 1))
    ax.view_init(elev=20, azim=35)


def _draw_band_planes(ax: Axes, axis: int, theta: float, colour: str) -> None:
    """The planes cᵢ = ±sin(θ/2) bounding Aᵢ(θ), translucent, and their circles on the sphere."""
    offset = math.sin(theta / 2)
    s, t = np.meshgrid(np.linspace(-1, 1, 2), np.linspace(-1, 1, 2))
    phi = np.linspace(0, 2 * np.pi, 100)
    radius = math.sqrt(max(0.0, 1 - offset**2))
    others = [a for a in range(3) if a != axis]
    for sign in (1, -1):
        plane, circle = np.empty((3, *s.shape)), np.empty((3, phi.size))
        plane[axis], plane[others[0]], plane[others[1]] = sign * offset, s, t
        circle[axis] = sign * offset
        circle[others[0]], circle[others[1]] = radius * np.cos(phi), radius * np.sin(phi)
        ax.plot_surface(*plane, color=colour, alpha=0.15, linewidth=0)
        ax.plot(*circle, color=colour, linewidth=1.5)


def _draw_projection(ax: Axes, c: np.ndarray, row: PercentileRow, colour: str) -> None:
    """Samples projected onto the (d_{axis+1}, d₃) plane with the band's edges as lines."""
    i = row.axis
    ax.scatter(c[:, i], c[:, 2], s=1, alpha=0.4, color="tab:blue")
    phi = np.linspace(0, 2 * np.pi, 200)
    ax.plot(np.cos(phi), np.sin(phi), color="0.7", linewidth=0.8)
    for deg, style, what in ((row.mc_mean_deg, "-", "MC"), (row.approx_deg, "--", "approx.")):
        offset = math.sin(math.radians(deg) / 2)
        label = rf"$\theta_{i + 1}^{{(99\%)}}$ {what} = {deg:.1f}°"
        ax.axvline(offset, color=colour, linestyle=style, linewidth=1.2, label=label)
        ax.axvline(-offset, color=colour, linestyle=style, linewidth=1.2)
    ax.set_xlabel(f"$d_{i + 1}$")
    ax.set_ylabel("$d_3$")
    ax.set_aspect("equal")
    ax.set_xlim(-1.05, 1.05)
    ax.set_ylim(-1.05, 1.05)
    ax.legend(fontsize=7, loc="center")  # the samples crowd the poles ±d₃


def percentile_figure(
    out: str | Path,
    samples: int = 1_000_000,
    repeats: int = 100,
    seed: int = 0,
    command: str | None = None,
) -> dict[str, Path]:
    """Write ``bingham_percentiles.json`` (settings, command, rows), ``.md`` (the table) and
    ``.png`` (`plot_percentile_bands`) into ``out``; returns their paths by suffix."""
    rows = percentile_rows(samples, repeats, seed)
    out = Path(out)
    record = {
        "command": command,
        "p": PERCENTILE,
        "samples": samples,
        "repeats": repeats,
        "seed": seed,
        "rows": [asdict(row) for row in rows],
    }
    figure = plot_percentile_bands(rows, seed)
    return {
        "json": write_json(out / "bingham_percentiles.json", record),
        "md": write_text(out / "bingham_percentiles.md", percentile_markdown(rows)),
        "png": save_figure(figure, out / "bingham_percentiles.png"),
    }


# -- the analysis scenes (Sec. 4.1 and 4.2) ---------------------------------------------------


@dataclass(frozen=True)
class Placed:
    """An upright, axis-aligned box or cylinder standing on the table.

    ``size`` holds the full extents (x, y, z) [m]; a cylinder's x and y are its diameter.
    """

    name: str
    kind: Literal["box", "cylinder"]
    centre: tuple[float, float]
    """x, y of the footprint's centre [m]."""
    size: tuple[float, float, float]

    def spec(self) -> ObjectSpec:
        """The object, its frame at the centre of its base (`symgrasp.sim.objects`)."""
        half = tuple(s / 2 for s in self.size)
        if self.kind == "box":
            part = Part("box", half, (0.0, 0.0, half[2]))
        else:
            part = Part("cylinder", (half[0], half[2]), (0.0, 0.0, half[2]))
        return ObjectSpec(self.name, self.kind, (part,), mass=0.2, friction=0.8)

    def pose(self) -> np.ndarray:
        """``T_world_object`` (4, 4): standing on the table top at ``centre``."""
        T = np.eye(4)
        T[:3, 3] = (*self.centre, TABLE_HEIGHT)
        return T

    def footprint_distance(self, xy: np.ndarray) -> np.ndarray:
        """Horizontal distance [m] of points ``xy [..., 2]`` to the footprint, 0 inside."""
        d = np.abs(xy - np.asarray(self.centre))
        if self.kind == "box":
            return np.linalg.norm(np.maximum(d - np.asarray(self.size[:2]) / 2, 0.0), axis=-1)
        return np.maximum(np.linalg.norm(d, axis=-1) - self.size[0] / 2, 0.0)

    def outline(self) -> Patch:
        """The footprint as an unfilled matplotlib patch."""
        style = {
            "fill": False,
            "edgecolor": "black",
            "linewidth": 1.0,
            "linestyle": "--",
            "zorder": 3,
        }
        if self.kind == "box":
            corner = (self.centre[0] - self.size[0] / 2, self.centre[1] - self.size[1] / 2)
            return Rectangle(corner, self.size[0], self.size[1], **style)
        return Circle(self.centre, self.size[0] / 2, **style)


LONG_BOX = Placed("box", "box", (WORKSPACE_SIZE / 2, WORKSPACE_SIZE / 2), (0.2, 0.06, 0.06))
"""Sec. 4.1: 60×60×200 mm at the workspace centre, long side along x (e_z must be ±y)."""

FLAT_CYLINDER = Placed(
    "cylinder", "cylinder", (WORKSPACE_SIZE / 2, WORKSPACE_SIZE / 2 + 0.1), (0.07, 0.07, 0.06)
)
"""Sec. 4.2: 70 mm across, 60 mm tall, on its flat face, 10 cm beside the box along +y."""


def render_depth(objects: Sequence[Placed]) -> DepthView:
    """One depth image of ``objects`` on the table from the default camera (workspace
    centre + (0.5, 0, 0.5) m, looking at the centre), as in Sec. 4.1."""
    world = World([o.spec() for o in objects], np.stack([o.pose() for o in objects]))
    intrinsic, T_world_camera = CameraIntrinsic(), default_extrinsic()
    return make_renderer(intrinsic).render(world, T_world_camera), intrinsic, T_world_camera


def slice_layer(height: float) -> int:
    """The voxel layer k holding world height ``height`` [m]: ⌊height / voxel⌋ (7 at 57 mm)."""
    k = math.floor(height / VOXEL + 1e-9)
    if not 0 <= k < RESOLUTION:
        raise ValueError(f"--height must lie in [0, {WORKSPACE_SIZE}) m, got {height}")
    return k


def busiest_layer(outputs: Iterable[dict[str, torch.Tensor]], validity: float) -> int:
    """The voxel layer k with the most voxels of validity ≥ ``validity``, summed over the
    network ``outputs`` (`GraspDetector.predict`); the lowest such layer on ties."""
    counts = sum((out["validity"] >= validity).sum(dim=(0, 1)).cpu().numpy() for out in outputs)
    return int(np.argmax(counts))


def choose_layer(
    height: float | None, outputs: Iterable[dict[str, torch.Tensor]], validity: float
) -> int:
    """`slice_layer` of ``height``, or `busiest_layer` where ``height`` is None."""
    return busiest_layer(outputs, validity) if height is None else slice_layer(height)


def voxel_centres_xy() -> np.ndarray:
    """x, y [m] of the voxel centres of one layer, ``[40, 40, 2]`` indexed [i, j]."""
    axis = (np.arange(RESOLUTION) + 0.5) * VOXEL
    return np.stack(np.meshgrid(axis, axis, indexing="ij"), axis=-1)


@dataclass(frozen=True)
class FieldSlice:
    """A detector's outputs in voxel layer ``layer``, arrays indexed [i (x), j (y)]."""

    representation: Representation
    layer: int
    score: np.ndarray
    """``[40, 40]`` gravity-rejection score."""
    validity: np.ndarray
    """``[40, 40]`` validity probability."""
    rotation: torch.Tensor
    """``[40, 40, C]`` float64: the representation's channels."""


def predict(detector: GraspDetector, view: DepthView) -> dict[str, torch.Tensor]:
    """Fuse the depth image into the 40³ TSDF and run the network: ``score`` and ``validity``
    ``[40, 40, 40]``, ``rotation`` ``[40, 40, 40, C]`` (`GraspDetector.predict`)."""
    return detector.predict(detector.fuse(*view).grid())


def cut_layer(
    out: dict[str, torch.Tensor], representation: Representation, layer: int
) -> FieldSlice:
    """Voxel layer ``layer`` of the network outputs ``out`` (`predict`)."""
    return FieldSlice(
        representation,
        layer,
        out["score"][:, :, layer].cpu().numpy(),
        out["validity"][:, :, layer].cpu().numpy(),
        out["rotation"][:, :, layer].cpu().double(),
    )


def parse_model_specs(specs: Sequence[str]) -> dict[str, str]:
    """``LABEL=PATH`` strings (``--model bingham2d=runs/a/best.pt``) as {label: path}."""
    models: dict[str, str] = {}
    for spec in specs:
        label, separator, path = spec.partition("=")
        if not separator or not label or not path:
            raise ValueError(f"--model must be LABEL=PATH, e.g. bingham2d=best.pt; got {spec!r}")
        if label in models:
            raise ValueError(f"--model: the label {label!r} is given twice")
        models[label] = path
    if not models:
        raise ValueError("--model: give at least one LABEL=PATH")
    return models


def check_validity(validity: float) -> None:
    """Raise ValueError unless the validity threshold is a probability."""
    if not 0.0 <= validity <= 1.0:
        raise ValueError(f"--validity must be in [0, 1], got {validity}")


def view_limits(objects: Sequence[Placed]) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper x, y corners [m] of the footprints plus `VIEW_MARGIN`, inside the
    workspace."""
    centres = np.array([o.centre for o in objects])
    halves = np.array([o.size[:2] for o in objects]) / 2
    lo = np.maximum((centres - halves).min(0) - VIEW_MARGIN, 0.0)
    hi = np.minimum((centres + halves).max(0) + VIEW_MARGIN, WORKSPACE_SIZE)
    return lo, hi


def _draw_field(
    ax: Axes, field: FieldSlice, valid: np.ndarray, objects: Sequence[Placed], cmap: str
) -> AxesImage:
    """The score of the valid voxels (the others blank) and the objects' outlines, framed to
    the footprints plus `VIEW_MARGIN`."""
    score = np.ma.masked_where(~valid, field.score)
    image = ax.imshow(
        score.T, origin="lower", extent=(0, WORKSPACE_SIZE, 0, WORKSPACE_SIZE), cmap=cmap
    )
    for o in objects:
        ax.add_patch(o.outline())
    lo, hi = view_limits(objects)
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal")
    return image


# -- rotation continuity (Sec. 4.1) -----------------------------------------------------------


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
        "neighbour_angle_deg_median": _statistic(np.median, angles),
        "neighbour_angle_deg_p90": _statistic(lambda a: np.percentile(a, 90), angles),
        "neighbour_flip_fraction": _statistic(lambda a: np.mean(a > 90), angles),
        "off_y_deg_median": _statistic(np.median, off_y),
    }


def _statistic(reduce: Callable[[np.ndarray], Any], values: np.ndarray) -> float | None:
    """``reduce(values)`` as a float, None for no values."""
    return float(reduce(values)) if len(values) else None


def plot_continuity(
    fields: dict[str, FieldSlice], validity: float, objects: Sequence[Placed]
) -> Figure:
    """Fig. fig:bingham_horizontal: one panel per model, the score of the valid voxels and
    their e_z projected to x–y, both ±e_z for ``bingham2d``."""
    lo, hi = view_limits(objects)
    height = 6 * (hi[1] - lo[1]) / (hi[0] - lo[0]) + 2
    figure, axes = plt.subplots(1, len(fields), figsize=(6 * len(fields), height), squeeze=False)
    xy = voxel_centres_xy()
    for ax, (label, field) in zip(axes[0], fields.items(), strict=True):
        valid = field.validity >= validity
        image = _draw_field(ax, field, valid, objects, "viridis")
        figure.colorbar(image, ax=ax, label="gravity-rejection score", orientation="horizontal")
        e_z = closing_axes(field)[valid]
        signs = (1, -1) if field.representation.name == "bingham2d" else (1,)
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
        ax.set_title(f"{label}: e_z at z = {(field.layer + 0.5) * VOXEL * 1e3:.1f} mm", fontsize=10)
    figure.tight_layout()
    return figure


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
        "layer_centre_m": (layer + 0.5) * VOXEL,
        "validity_threshold": validity,
        "statistic": inspect.cleandoc(continuity_statistics.__doc__ or ""),
        "models": {
            label: {
                "path": str(models[label]),
                "representation": field.representation.name,
                **continuity_statistics(
                    closing_axes(field),
                    field.validity >= validity,
                    field.representation.name == "bingham2d",
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


# -- rotation distribution (Sec. 4.2) ---------------------------------------------------------


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
        mine = (nearest == index) & (distance[:, index] <= VOXEL)
        stats[o.name] = {
            "voxels": int(mine.sum()),
            "mean_confidence": _statistic(np.mean, axes.confidence[mine]),
            "mean_spread_deg": _statistic(np.mean, spread[mine]),
        }
    return stats


def plot_distribution(
    field: FieldSlice, valid: np.ndarray, axes: SampledAxes, objects: Sequence[Placed]
) -> Figure:
    """Fig. fig:bingham_sampling: the score of the valid voxels in grey and every sampled e_z
    as a segment through its voxel centre, projected to x–y, coloured by confidence."""
    figure, ax = plt.subplots(figsize=(7.5, 6))
    _draw_field(ax, field, valid, objects, "Greys")
    half = ARROW_LENGTH / 2 * axes.samples[..., :2]  # [M, n, 2]
    centre = axes.xy[:, None]
    segments = np.stack([centre - half, centre + half], axis=-2).reshape(-1, 2, 2)
    lines = LineCollection(segments, cmap="plasma", linewidths=0.6, alpha=0.6)
    lines.set_array(np.repeat(axes.confidence, axes.samples.shape[1]))
    ax.add_collection(lines)
    figure.colorbar(lines, ax=ax, label="confidence (λ₃−λ₂)+(λ₃−λ₁)", shrink=0.8)
    n = axes.samples.shape[1]
    z_mm = (field.layer + 0.5) * VOXEL * 1e3
    ax.set_title(f"{field.representation.name}: {n} samples of e_z per voxel at z = {z_mm:.1f} mm")
    figure.tight_layout()
    return figure


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
        "layer_centre_m": (layer + 0.5) * VOXEL,
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


# -- files -----------------------------------------------------------------------------------


def write_text(path: Path, text: str) -> Path:
    """``text`` as UTF-8 at ``path``, atomically."""
    return write_atomic(path, lambda file: file.write(text.encode("utf-8")))


def write_json(path: Path, data: dict[str, Any]) -> Path:
    """``data`` as indented JSON at ``path``, atomically."""
    return write_text(path, json.dumps(data, indent=1, ensure_ascii=False) + "\n")


def save_figure(figure: Figure, path: Path) -> Path:
    """``figure`` as a PNG at ``path``, atomically; the figure is closed."""
    try:
        return write_atomic(path, lambda file: figure.savefig(file, format="png", dpi=120))
    finally:
        plt.close(figure)
