"""The band angles θᵢ^(99%) of 2D Bingham distributions (Ko et al. 2024, Appx. A): Eq. 12
against Monte Carlo, Figs. 7 and 8.

Eigenvalues are ascending, λ₁ ≤ λ₂ ≤ λ₃ = 0 (Eq. 5), and ``axis`` is 0-based as
in `Bingham.percentile_angle` (axis 0 ↔ λ₁ ↔ the paper's θ₁).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import torch
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from tqdm import tqdm

from symgrasp.analysis.files import save_figure, write_json, write_text
from symgrasp.bingham import Bingham
from symgrasp.folders import PICTURES, writes_folder

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
"""λ of Fig. 8, drawn by `percentile_figure`."""

DOT_SAMPLES = 3000
"""Bingham samples drawn in the sphere plot of `percentile_figure`."""


@dataclass(frozen=True)
class PercentileRow:
    """θᵢ^(p) of B(diag(λ)) for one λ and one axis; angles in degrees."""

    lam: Shape
    axis: int
    """0-based: the band is orthogonal to the eigenvector of λ[axis]."""
    approx_deg: float
    """2 erf⁻¹(p)/√(λ₃ − λᵢ) (Eq. 12)."""
    mc_mean_deg: float
    """Mean of the Monte-Carlo estimates (`Bingham.percentile_angle_mc`)."""
    mc_std_deg: float
    """Their population standard deviation over the repeats."""
    relative_difference: float
    """(approx − MC mean) / MC mean."""


def percentile_row(
    lam: Shape,
    axis: int,
    samples: int,
    repeats: int,
    seed: int,
    p: float = PERCENTILE,
    drawn: Callable[[int], object] | None = None,
) -> PercentileRow:
    """θ_{axis+1}^(p) of B(diag(λ)) in float64 by Eq. 12 and by ``repeats``
    Monte-Carlo estimates of ``samples`` exact draws each, the r-th seeded ``seed + r``;
    ``drawn(samples)`` is called after each estimate (a progress bar's ``update``)."""
    if samples < 1 or repeats < 1:
        raise ValueError(f"--samples and --repeats must be ≥ 1, got {samples} and {repeats}")
    distribution = Bingham(torch.diag(torch.tensor(lam, dtype=torch.float64)))
    approx = math.degrees(distribution.percentile_angle(p, axis).item())
    estimates = []
    for r in range(repeats):
        generator = torch.Generator().manual_seed(seed + r)
        estimates.append(distribution.percentile_angle_mc(p, axis, samples, generator).item())
        if drawn is not None:
            drawn(samples)
    estimates = np.degrees(estimates)
    mean = float(estimates.mean())
    return PercentileRow(lam, axis, approx, mean, float(estimates.std()), (approx - mean) / mean)


def percentile_rows(
    samples: int, repeats: int, seed: int, shapes: Sequence[Shape] = SHAPES
) -> list[PercentileRow]:
    """`percentile_row` for every λ of ``shapes`` and i = 1, 2, with a progress bar of the
    draws (its rate and the time left show after the first estimate)."""
    cases = list(itertools.product(shapes, (0, 1)))
    with tqdm(total=len(cases) * repeats * samples, desc="Bingham draws", unit="draw",
              unit_scale=True) as bar:  # fmt: skip
        return [
            percentile_row(lam, axis, samples, repeats, seed, drawn=bar.update)
            for lam, axis in cases
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
    """Fig. 8: `DOT_SAMPLES` samples of
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


@writes_folder(PICTURES)
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
