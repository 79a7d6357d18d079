"""What ``make demo`` runs until the grasp pipeline exists: the 2D Bingham distribution at work.

A closing-axis distribution like the paper's Fig. 6 (λ = (−50, −10, 0)) is sampled, fitted back
by maximum likelihood, and drawn next to distributions of other shapes (the paper's Fig. 5),
so a reader can see how the eigenvalues shape the uncertainty about e_z and that +e_z and −e_z
are the same parameter set.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import torch

from symgrasp.bingham import Bingham, fit

SHAPES = {
    "λ = (−50, −10, 0)": (-50.0, -10.0, 0.0),
    "λ = (−200, −200, 0)": (-200.0, -200.0, 0.0),
    "λ = (−100, −1, 0)": (-100.0, -1.0, 0.0),
    "λ = (−5, −5, 0)": (-5.0, -5.0, 0.0),
}
NUM_SAMPLES = 2000


def _rotation(seed: int) -> torch.Tensor:
    """A random rotation whose third column (the mode) is tilted 40–70° from the vertical."""
    generator = torch.Generator().manual_seed(seed)
    tilt, azimuth = torch.rand(2, generator=generator, dtype=torch.float64) * torch.tensor(
        [0.5, 2 * math.pi]
    )
    tilt = tilt + 0.7
    ct, st, ca, sa = tilt.cos(), tilt.sin(), azimuth.cos(), azimuth.sin()
    about_x = torch.tensor([[1, 0, 0], [0, ct, -st], [0, st, ct]], dtype=torch.float64)
    about_z = torch.tensor([[ca, -sa, 0], [sa, ca, 0], [0, 0, 1]], dtype=torch.float64)
    return about_z @ about_x


def _draw(ax, dist: Bingham, samples: torch.Tensor, title: str) -> None:
    u, v = torch.meshgrid(
        torch.linspace(0, 2 * math.pi, 40), torch.linspace(0, math.pi, 20), indexing="ij"
    )
    ax.plot_wireframe(u.cos() * v.sin(), u.sin() * v.sin(), v.cos(), color="0.85", linewidth=0.4)
    x = samples.numpy()
    ax.scatter(x[:, 0], x[:, 1], x[:, 2], s=2, alpha=0.5, color="tab:blue")
    mode = dist.mode.numpy() * 1.35
    for sign in (1, -1):  # both ±mode: one parameter set, two physical closing directions
        ax.quiver(0, 0, 0, *(sign * mode), color="tab:red", linewidth=2, arrow_length_ratio=0.15)
    ax.set_title(f"{title}\nconfidence {dist.confidence.item():.0f}", fontsize=9)
    ax.set_box_aspect((1, 1, 1))
    ax.view_init(elev=20, azim=35)
    ax.set_axis_off()


def run_demo(out: str | Path = "out/demo", seed: int = 0) -> dict:
    """Sample, fit and plot Bingham distributions; writes ``bingham.png`` and ``summary.json``."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    generator = torch.Generator().manual_seed(seed)
    rotation = _rotation(seed)

    figure = plt.figure(figsize=(12, 4.2))
    summary: dict = {"seed": seed, "num_samples": NUM_SAMPLES, "distributions": []}
    for i, (title, lam) in enumerate(SHAPES.items()):
        A = rotation @ torch.diag(torch.tensor(lam, dtype=torch.float64)) @ rotation.T
        truth = Bingham(A)
        samples = truth.sample((NUM_SAMPLES,), generator=generator)
        fitted = fit(samples)
        fitted_lam = fitted.eigenvalues - fitted.eigenvalues[-1]
        mode_error = math.degrees(
            math.acos(min(1.0, abs(torch.dot(fitted.mode, truth.mode).item())))
        )
        summary["distributions"].append(
            {
                "eigenvalues": list(lam),
                "fitted_eigenvalues": [round(x, 3) for x in fitted_lam.tolist()],
                "fitted_mode_error_deg": round(mode_error, 3),
                "confidence": truth.confidence.item(),
                "percentile_99_deg_approx": [
                    round(math.degrees(truth.percentile_angle(0.99, axis).item()), 2)
                    for axis in (0, 1)
                ],
                "percentile_99_deg_samples": [
                    round(
                        math.degrees(
                            truth.percentile_angle_mc(0.99, axis, 20_000, generator).item()
                        ),
                        2,
                    )
                    for axis in (0, 1)
                ],
            }
        )
        _draw(figure.add_subplot(1, len(SHAPES), i + 1, projection="3d"), truth, samples, title)
    figure.suptitle(
        "2D Bingham distributions of the closing axis e_z: samples (blue) and ±mode (red)"
    )
    figure.tight_layout(rect=(0, 0, 1, 0.93))
    picture = out / "bingham.png"
    figure.savefig(picture, dpi=110)
    plt.close(figure)
    (out / "summary.json").write_text(json.dumps(summary, indent=2))

    for entry in summary["distributions"]:
        print(
            f"λ = {tuple(entry['eigenvalues'])}: fitted {tuple(entry['fitted_eigenvalues'])}, "
            f"mode error {entry['fitted_mode_error_deg']:.2f}°, confidence {entry['confidence']:.0f}, "
            f"θ99 approx {entry['percentile_99_deg_approx']}° vs samples {entry['percentile_99_deg_samples']}°"
        )
    print(f"wrote {picture} and {out / 'summary.json'}")
    return summary
