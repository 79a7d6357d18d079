"""``symgrasp detect`` (grasps in a depth image or a point cloud) and ``symgrasp export`` (a
checkpoint made shippable): the detector's commands (`symgrasp.detect`). The detector's own
options (`add_detector_options`) are ``symgrasp serve``'s too."""

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
        help="detect grasps in a depth image or a point cloud",
        description="Fuse a depth image (or a point cloud, as the depth image its camera would "
        "take) into the workspace TSDF, run a grasp detector and write "
        "grasps.json (T_world_tcp, scores, confidences; best first), grasps.png (points and the "
        "top grasps coloured by score) and grasps.html (interactive 3-D view) into --out. The "
        "workspace is the 30 cm cube from --workspace-origin, with the table 5 cm above its "
        "floor, as in training. No grasp is an answer (exit 0, an empty grasp list); when the "
        "input shows why (no depth point inside the workspace, an implausible depth, a "
        "network output that is not finite), a 'warning:' line on stderr says which.",
    )
    given = parser.add_mutually_exclusive_group(required=True)
    given.add_argument(
        "--depth",
        type=input_file,
        help="depth image: .npy of floating-point metres, or a 16-bit .png in units of "
        "--png-scale (millimetres by default; 0 = no measurement); an 8-bit .png is refused",
    )
    given.add_argument(
        "--points",
        type=input_file,
        help="point cloud [m]: .npy of (N, 3) or organised (H, W, 3) floats (NaN rows missing) "
        "or .ply (its vertices' x, y, z), seen from --extrinsic or --viewpoint; it becomes "
        "the depth image its camera would take, each pixel the nearest point (docs/detect.md)",
    )
    parser.add_argument(
        "--intrinsic",
        type=input_file,
        help='JSON: {"fx", "fy", "cx", "cy"[, "width", "height"]} or a 3×3 matrix; needed '
        "with --depth; with --points the sensor's camera (width and height for an unorganised "
        "cloud), else a virtual camera",
    )
    pose = parser.add_mutually_exclusive_group()
    pose.add_argument(
        "--extrinsic", type=input_file, help="JSON: the 4×4 camera pose T_world_camera [m]"
    )
    pose.add_argument(
        "--viewpoint",
        type=number(-1e3, 1e3),
        nargs=3,
        metavar=("X", "Y", "Z"),
        help="with --points instead of --extrinsic: where the camera stood [m, world frame]; "
        "a camera there looking at the workspace centre",
    )
    parser.add_argument(
        "--points-frame",
        choices=("world", "camera"),
        default="world",
        help="the frame --points are in: world (default) or camera (the sensor's own, with "
        "--extrinsic)",
    )
    parser.add_argument(
        "--png-scale",
        type=number(1e-9, 1e3),
        default=0.001,
        help="metres per unit of a 16-bit --depth .png, the sensor's depth scale (default: "
        "0.001, millimetres)",
    )
    parser.add_argument("--out", type=output_folder_path, required=True, help="output folder")
    add_detector_options(parser)
    parser.set_defaults(run=_run_detect)


def add_detector_options(parser: argparse.ArgumentParser) -> None:
    """The options of the detector a command loads (`symgrasp detect`, `symgrasp serve`):
    the model and how its output is decoded; `detector_options` reads them."""
    parser.add_argument(
        "--model",
        type=parse_model,
        default="bingham2d-robotiq-2f85",
        metavar=MODEL_METAVAR,
        help="shipped model name or checkpoint path (default: bingham2d-robotiq-2f85)",
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
    parser.add_argument(
        "--fill-holes",
        type=integer(0, 64),
        default=0,
        metavar="PIXELS",
        help="fill the depth image's holes up to PIXELS from their edge with the farthest seen "
        "neighbour before fusion, as a real sensor leaves them at object edges (default: 0, "
        "none; docs/detect.md)",
    )
    parser.add_argument("--device", default="auto", help="auto, cpu or cuda (default: auto)")


def load_detector(args: argparse.Namespace):  # -> GraspDetector (imported here, not above)
    """The detector `add_detector_options`'s options ask for."""
    from symgrasp.detect import GraspDetector

    return GraspDetector.from_pretrained(
        args.model,
        device=args.device,
        validity_threshold=args.validity,
        confidence_threshold=confidence_threshold(args),
        top_k=args.top_k,
        samples_per_voxel=args.samples_per_voxel,
        workspace_origin=tuple(args.workspace_origin),
        fill_holes=args.fill_holes,
    )


def _run_detect(args: argparse.Namespace) -> None:
    from symgrasp.folders import PICTURES, output_folder

    if args.depth is not None and (args.intrinsic is None or args.extrinsic is None):
        raise ValueError("--depth needs --intrinsic and --extrinsic (its camera and pose)")
    if args.points is not None and args.extrinsic is None and args.viewpoint is None:
        raise ValueError("--points needs --extrinsic or --viewpoint: the rays the TSDF fuses "
                         "start at the camera")  # fmt: skip
    if args.depth is not None and args.viewpoint is not None:
        raise ValueError("--viewpoint goes with --points; a depth image needs --extrinsic")
    if args.points_frame == "camera" and args.extrinsic is None:
        raise ValueError("--points-frame camera needs --extrinsic (a viewpoint does not fix "
                         "the camera's axes)")  # fmt: skip
    with output_folder(args.out, PICTURES, "--out"):  # checked before the model loads
        _detect(args)


def _detect(args: argparse.Namespace) -> None:
    from symgrasp.detect.files import (
        load_depth,
        load_extrinsic,
        load_intrinsic,
        load_points,
        write_detection,
    )
    from symgrasp.perception import depth_to_points, points_view

    extrinsic = None if args.extrinsic is None else load_extrinsic(args.extrinsic)
    if args.depth is not None:
        depth = load_depth(args.depth, args.png_scale)
        intrinsic = load_intrinsic(args.intrinsic, depth.shape)
    else:
        points = load_points(args.points)
        intrinsic = None
        if args.intrinsic is not None:
            intrinsic = load_intrinsic(
                args.intrinsic, points.shape[:2] if points.ndim == 3 else None
            )
    detector = load_detector(args)
    with warnings.catch_warnings(record=True) as caught:  # one line each, as errors are
        warnings.simplefilter("always")
        if args.depth is not None:
            grasps = detector.detect(depth, intrinsic, extrinsic)
        else:
            grasps = detector.detect_points(
                points, extrinsic, viewpoint=args.viewpoint, intrinsic=intrinsic,
                frame=args.points_frame,
            )  # fmt: skip
            depth, intrinsic, extrinsic = points_view(
                points, extrinsic, viewpoint=args.viewpoint, intrinsic=intrinsic,
                frame=args.points_frame, origin=detector.origin,
            )  # fmt: skip
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
