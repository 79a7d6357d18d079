"""``symgrasp detect`` (grasps in a depth image) and ``symgrasp export`` (a checkpoint made
shippable): the detector's commands (`symgrasp.detect`)."""

from __future__ import annotations

import argparse
import sys
import warnings

from symgrasp.arguments import integer, number
from symgrasp.cli.options import (
    MODEL_METAVAR,
    PROBABILITY,
    add_confidence_options,
    confidence_threshold,
    input_file,
    output_folder_path,
    output_path,
    parse_model,
)
from symgrasp.config import DEFAULT_VALIDITY


def add(subparsers: argparse._SubParsersAction) -> None:
    _add_detect(subparsers)
    _add_export(subparsers)


def _add_detect(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "detect",
        help="detect grasps in a depth image",
        description="Fuse a depth image into the workspace TSDF, run a grasp detector and write "
        "grasps.json (T_world_tcp, scores, confidences; best first), grasps.png (points and the "
        "top grasps coloured by score) and grasps.html (interactive 3-D view) into --out. The "
        "workspace is the 30 cm cube from --workspace-origin, with the table 5 cm above its "
        "floor, as in training. No grasp is an answer (exit 0, an empty grasp list); when the "
        "input shows why (no depth point inside the workspace, an implausible depth, a "
        "network output that is not finite), a 'warning:' line on stderr says which.",
    )
    parser.add_argument(
        "--depth",
        type=input_file,
        required=True,
        help="depth image: .npy of floating-point metres, or a 16-bit .png in units of "
        "--png-scale (millimetres by default); an 8-bit .png is refused",
    )
    parser.add_argument(
        "--intrinsic",
        type=input_file,
        required=True,
        help='JSON: {"fx", "fy", "cx", "cy"[, "width", "height"]} or a 3×3 matrix',
    )
    parser.add_argument(
        "--extrinsic",
        type=input_file,
        required=True,
        help="JSON: the 4×4 camera pose T_world_camera [m]",
    )
    parser.add_argument(
        "--model",
        type=parse_model,
        default="bingham2d-robotiq-2f85",
        metavar=MODEL_METAVAR,
        help="shipped model name or checkpoint path (default: bingham2d-robotiq-2f85)",
    )
    parser.add_argument("--out", type=output_folder_path, required=True, help="output folder")
    parser.add_argument(
        "--png-scale",
        type=number(1e-9, 1e3),
        default=0.001,
        help="metres per unit of a 16-bit --depth .png (default: 0.001, millimetres)",
    )
    parser.add_argument(
        "--workspace-origin",
        type=number(-1e3, 1e3),
        nargs=3,
        default=(0.0, 0.0, 0.0),
        metavar=("X", "Y", "Z"),
        help="world position of the workspace cube's corner [m] (default: 0 0 0)",
    )
    parser.add_argument(
        "--validity",
        type=PROBABILITY,
        default=DEFAULT_VALIDITY,
        help=f"validity threshold (default: {DEFAULT_VALIDITY}, docs/detect.md)",
    )
    add_confidence_options(parser)
    parser.add_argument(
        "--top-k", type=integer(1, 10**6), default=None, help="keep the best K grasps"
    )
    parser.add_argument(
        "--samples-per-voxel",
        type=integer(0, 1000),
        default=0,
        help="draw N closing axes per voxel from the Bingham output (default: 0, the mode)",
    )
    parser.add_argument("--device", default="auto", help="auto, cpu or cuda (default: auto)")
    parser.set_defaults(run=_run_detect)


def _run_detect(args: argparse.Namespace) -> None:
    from symgrasp.folders import PICTURES, output_folder

    with output_folder(args.out, PICTURES, "--out"):  # checked before the model loads
        _detect(args)


def _detect(args: argparse.Namespace) -> None:
    from symgrasp.detect import GraspDetector
    from symgrasp.detect.files import load_depth, load_extrinsic, load_intrinsic, write_detection
    from symgrasp.perception import depth_to_points

    depth = load_depth(args.depth, args.png_scale)
    intrinsic = load_intrinsic(args.intrinsic, depth.shape)
    extrinsic = load_extrinsic(args.extrinsic)
    detector = GraspDetector.from_pretrained(
        args.model,
        device=args.device,
        validity_threshold=args.validity,
        confidence_threshold=confidence_threshold(args),
        top_k=args.top_k,
        samples_per_voxel=args.samples_per_voxel,
        workspace_origin=tuple(args.workspace_origin),
    )
    with warnings.catch_warnings(record=True) as caught:  # one line each, as errors are
        warnings.simplefilter("always")
        grasps = detector.detect(depth, intrinsic, extrinsic)
    for warning in caught:
        print(f"warning: {warning.message}", file=sys.stderr)
    volume = detector.fuse(depth, intrinsic, extrinsic)  # again, for the pictures
    points = depth_to_points(depth, intrinsic, extrinsic, origin=detector.origin)
    paths = write_detection(args.out, detector, volume, grasps, points)
    found = f"{len(grasps)} grasps" if grasps else "no grasp found (the scene is drawn)"
    print(f"{found}; " + ", ".join(str(p) for p in paths.values()))


def _add_export(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "export",
        help="strip a training checkpoint down to a shippable model",
        description="Copy a checkpoint written by `symgrasp train` without its optimizer state "
        "and, for a run with --ema, its trained weights next to the average (what symgrasp "
        "ships in symgrasp/detect/models/).",
    )
    parser.add_argument(
        "checkpoint", type=input_file, help="checkpoint path, e.g. runs/NAME/best.pt"
    )
    parser.add_argument("out", type=output_path, help="output .pt path")
    parser.set_defaults(run=_run_export)


def _run_export(args: argparse.Namespace) -> None:
    from symgrasp.detect import export_model

    print(export_model(args.checkpoint, args.out))
