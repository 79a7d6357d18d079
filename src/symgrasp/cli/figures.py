"""``symgrasp figures``: the paper's analysis figures, each recorded with the command that
made it (`symgrasp.analysis`)."""

from __future__ import annotations

import argparse
import shlex

from symgrasp.arguments import integer, number
from symgrasp.cli.options import (
    MODEL_METAVAR,
    PROBABILITY,
    SEED,
    output_folder_path,
    parse_model,
    parse_model_spec,
)
from symgrasp.config import DEFAULT_VALIDITY
from symgrasp.workspace import WORKSPACE_SIZE


def _command(*words: object) -> str:
    """The shell command that reproduces a run, recorded next to its results."""
    return shlex.join(["symgrasp", *(str(w) for w in words)])


def add(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "figures",
        help="the paper's analysis figures",
        description="The analysis figures of Ko et al. (2024), Sec. 4.1, 4.2 and Appx. A, each "
        "as a PNG and a JSON holding its numbers and this command (docs/figures.md).",
    )
    actions = parser.add_subparsers(
        dest="action",
        required=True,
        metavar="ACTION",
        help="which figure (percentiles, continuity, distribution)",
    )
    percentiles = actions.add_parser(
        "percentiles",
        help="θᵢ^(99%%) of 2D Bingham distributions: approximation vs Monte Carlo",
        description="For several λ = (λ1, λ2, 0) and i = 1, 2, the angle θᵢ^(99%) of the band "
        "holding 99% of B(diag(λ)) by the approximation 2 erf⁻¹(p)/√(λ3 − λi) (Appx. A) and by "
        "--repeats Monte-Carlo estimates of --samples draws each (mean ± std). Writes "
        "bingham_percentiles.json, .md (the table) and .png (samples of B(diag(−50, −10, 0)) "
        "with the bounding planes, as in the paper's Appx. A) into --out.",
    )
    percentiles.add_argument(
        "--samples",
        type=integer(1, 10**7),
        default=1_000_000,
        help="Bingham draws per Monte-Carlo estimate (default: 1000000)",
    )
    percentiles.add_argument(
        "--repeats",
        type=integer(1, 10_000),
        default=100,
        help="Monte-Carlo estimates per row (default: 100)",
    )
    percentiles.add_argument(
        "--seed",
        type=SEED,
        default=0,
        help="seed of the first estimate; +r for the r-th (default: 0)",
    )
    percentiles.add_argument(
        "--out",
        type=output_folder_path,
        default="docs/figures",
        help="output folder (default: docs/figures)",
    )
    percentiles.set_defaults(run=_run_percentiles)

    continuity = actions.add_parser(
        "continuity",
        help="score and e_z fields of several models over a long box",
        description="Sec. 4.1: a 60×60×200 mm box lies at the workspace centre along x; one "
        "depth image from centre + (0.5, 0, 0.5) m is fused into the TSDF and each model's score "
        "(valid voxels only) and decoded closing axis e_z (both ±e_z for bingham2d) are drawn in "
        "the voxel layer at --height, one panel per model. Writes rotation_continuity.png and "
        ".json (valid voxels, neighbour-angle and ±y-alignment statistics) into --out.",
    )
    continuity.add_argument(
        "--model",
        action="append",
        type=parse_model_spec,
        required=True,
        metavar="LABEL=PATH",
        help="a panel: its title and a checkpoint path or shipped model name; repeat for more "
        "panels, e.g. --model bingham2d=A.pt --model rotmat6d=B.pt",
    )
    _add_slice_options(continuity)
    continuity.set_defaults(run=_run_continuity)

    distribution = actions.add_parser(
        "distribution",
        help="closing axes sampled from a Bingham model over a box and a cylinder",
        description="Sec. 4.2: the box of `continuity` and a flat cylinder (70 mm across, "
        "60 mm tall) 10 cm beside it along +y; at every valid voxel of the layer at --height, "
        "--samples closing axes e_z are drawn from the predicted Bingham distribution and shown "
        "as segments coloured by confidence. Writes rotation_distribution.png and .json (per "
        "object: voxels, mean confidence, mean angular spread) into --out.",
    )
    distribution.add_argument(
        "--model",
        type=parse_model,
        required=True,
        metavar=MODEL_METAVAR,
        help="checkpoint path or shipped model name (a Bingham model)",
    )
    distribution.add_argument(
        "--samples", type=integer(1, 1000), default=30, help="e_z drawn per voxel (default: 30)"
    )
    distribution.add_argument("--seed", type=SEED, default=0, help="sampling seed (default: 0)")
    _add_slice_options(distribution)
    distribution.set_defaults(run=_run_distribution)


def _height(text: str) -> float | None:
    """``--height``: metres inside the workspace, or None for 'auto'."""
    return None if text == "auto" else number(0.0, WORKSPACE_SIZE)(text)


def _height_word(height: float | None) -> str:
    """``--height``'s value as typed: 'auto' for None."""
    return "auto" if height is None else str(height)


def _add_slice_options(parser: argparse.ArgumentParser) -> None:
    """The options shared by the figures that cut one voxel layer out of a detector's output."""
    parser.add_argument(
        "--height",
        type=_height,
        default=0.057,
        help="world height of the layer [m], the table top being at 0.05, or 'auto' for the "
        "layer with the most valid voxels (default: 0.057, the paper's z = 57 mm)",
    )
    parser.add_argument(
        "--validity",
        type=PROBABILITY,
        default=DEFAULT_VALIDITY,
        help="voxels whose validity probability is below this are neither drawn nor counted "
        f"(default: {DEFAULT_VALIDITY}, the detector's)",
    )
    parser.add_argument(
        "--out",
        type=output_folder_path,
        default="docs/figures",
        help="output folder (default: docs/figures)",
    )


def _run_percentiles(args: argparse.Namespace) -> None:
    from symgrasp.analysis import percentile_figure

    command = _command(
        "figures", "percentiles", "--samples", args.samples, "--repeats", args.repeats,
        "--seed", args.seed, "--out", args.out,
    )  # fmt: skip
    paths = percentile_figure(args.out, args.samples, args.repeats, args.seed, command)
    print(paths["md"].read_text(encoding="utf-8"), end="")
    print(", ".join(str(p) for p in paths.values()))


def _run_continuity(args: argparse.Namespace) -> None:
    from symgrasp.analysis import continuity_figure, parse_model_specs

    models = parse_model_specs(args.model)
    words = [w for spec in args.model for w in ("--model", spec)]
    command = _command(
        "figures", "continuity", *words, "--height", _height_word(args.height),
        "--validity", args.validity, "--out", args.out,
    )  # fmt: skip
    paths = continuity_figure(models, args.out, args.height, args.validity, command)
    print(", ".join(str(p) for p in paths.values()))


def _run_distribution(args: argparse.Namespace) -> None:
    from symgrasp.analysis import distribution_figure

    command = _command(
        "figures", "distribution", "--model", args.model, "--samples", args.samples,
        "--seed", args.seed, "--height", _height_word(args.height),
        "--validity", args.validity, "--out", args.out,
    )  # fmt: skip
    paths = distribution_figure(
        args.model, args.out, args.samples, args.height, args.validity, args.seed, command
    )
    print(", ".join(str(p) for p in paths.values()))
