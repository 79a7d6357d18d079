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
    PLANNER_METAVAR,
    add_decoding_options,
    add_shared,
    decoding_options,
    input_file,
    output_folder_path,
    output_path,
    parse_device,
    parse_model,
    parse_planner,
)
from symgrasp.names import planner_kind


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
    add_detector_options(parser, planners=True)
    add_shared(
        parser,
        "gripper",
        "the hand the grasps are for, a built-in's name or a spec file: for vgn (default: "
        "franka) and your own planner function; a model decides its own",
    )
    parser.set_defaults(run=_run_detect)


def add_detector_options(parser: argparse.ArgumentParser, planners: bool = False) -> None:
    """The options of the detector a command loads (`symgrasp detect`, `symgrasp serve`):
    the model and how its output is decoded (`load_detector` reads them); ``planners``:
    ``--model`` (alias ``--planner``) may also name VGN's network or a user's planner."""
    if planners:
        parser.add_argument(
            "--model",
            "--planner",
            dest="model",
            type=parse_planner,
            default="bingham2d-robotiq-2f85",
            metavar=PLANNER_METAVAR,
            help="shipped model name, checkpoint path, vgn (VGN's network, its weights in the "
            "data folder: docs/peers.md) or your own planner as package.module:NAME "
            "(docs/benchmark.md) (default: bingham2d-robotiq-2f85)",
        )
    else:
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
    add_decoding_options(parser)
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
    parser.add_argument(
        "--table-scale",
        action="store_true",
        help="divide the depth image by the depth scale that puts the table where the "
        "workspace says (5 cm above --workspace-origin, z up): undoes a sensor's depth scale "
        "error; needs the table in view (docs/detect.md)",
    )
    parser.add_argument(
        "--depth-scale",
        type=number(0, float("inf")),  # its range is the detector's to check
        default=None,
        metavar="G",
        help="divide the depth image by G, the sensor's depth over the true depth, read once "
        "(e.g. by symgrasp.perception.table_depth_scale off a calibration image of the table): "
        "--table-scale's correction for a sensor whose scale error stays put, at one division "
        "per image; not with --table-scale (default: none; docs/detect.md)",
    )
    parser.add_argument(
        "--approach-check",
        action="store_true",
        help="return only the grasps whose open hand, swept in from the pre-grasp, keeps 1 mm "
        "from the seen surface and the table: the check the declutter benchmark makes before "
        "it executes the first of them (loads MuJoCo for the hand's boxes; docs/detect.md)",
    )
    parser.add_argument(
        "--optimize",
        action="store_true",
        help="run the network as a TorchScript graph made for inference: ≈ 0.45× the forward "
        "time on a CPU, outputs equal up to float rounding (docs/detect.md, 'Latency')",
    )
    parser.add_argument(
        "--device", type=parse_device, default="auto", help="auto, cpu or cuda (default: auto)"
    )


def load_detector(args: argparse.Namespace):  # -> GraspDetector (imported here, not above)
    """The detector `add_detector_options`'s options ask for."""
    from symgrasp.detect import GraspDetector

    return GraspDetector.from_pretrained(
        args.model,
        device=args.device,
        operating_point=not args.no_operating_point,
        **decoding_options(args),
        top_k=args.top_k,
        samples_per_voxel=args.samples_per_voxel,
        workspace_origin=tuple(args.workspace_origin),
        fill_holes=args.fill_holes,
        table_scale=args.table_scale,
        depth_scale=args.depth_scale,
        approach_check=args.approach_check,
        optimize=args.optimize,
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
    _check_planner_options(args)
    with output_folder(args.out, PICTURES, "--out"):  # checked before the model loads
        _detect(args)


def _detect(args: argparse.Namespace) -> None:
    from symgrasp.detect.detector import check_views
    from symgrasp.detect.files import (
        load_depth,
        load_extrinsic,
        load_intrinsic,
        load_points,
        write_detection,
    )
    from symgrasp.detect.planner import Observation
    from symgrasp.perception import depth_to_points, points_view

    planner = _planner(args)
    origin = getattr(planner, "origin", (0.0, 0.0, 0.0))
    extrinsic = None if args.extrinsic is None else load_extrinsic(args.extrinsic)
    cloud = None
    if args.depth is not None:
        depth = load_depth(args.depth, args.png_scale)
        intrinsic, pose = load_intrinsic(args.intrinsic, depth.shape), extrinsic
    else:
        cloud = load_points(args.points)
        given = None
        if args.intrinsic is not None:
            given = load_intrinsic(args.intrinsic, cloud.shape[:2] if cloud.ndim == 3 else None)
        # the image its camera would take: what every planner and the pictures read
        depth, intrinsic, pose = points_view(
            cloud, extrinsic, viewpoint=args.viewpoint, intrinsic=given,
            frame=args.points_frame, origin=origin,
        )  # fmt: skip
    with warnings.catch_warnings(record=True) as caught:  # one line each, as errors are
        warnings.simplefilter("always")
        if cloud is not None and hasattr(planner, "detect_points"):  # a cloud's own warnings
            grasps = planner.detect_points(
                cloud, extrinsic, viewpoint=args.viewpoint, intrinsic=given,
                frame=args.points_frame,
            )  # fmt: skip
        elif hasattr(planner, "detect"):  # a detector, VGN: their own input checks and timing
            grasps = planner.detect(depth, intrinsic, pose)
        else:
            grasps = list(planner.plan(Observation(*check_views(depth, intrinsic, pose))))
    for warning in caught:
        print(f"warning: {warning.message}", file=sys.stderr)
    grasps = grasps[: args.top_k]
    volume = _fused(planner, depth, intrinsic, pose, origin)  # again, for the pictures
    points = depth_to_points(depth, intrinsic, pose, origin=origin)
    paths = write_detection(args.out, planner, volume, grasps, points)
    found = f"{len(grasps)} grasps" if grasps else "no grasp found (the scene is drawn)"
    print(f"{found}; " + ", ".join(str(p) for p in paths.values()))


def _check_planner_options(args: argparse.Namespace) -> None:
    """Refuse the options that do not apply to the planner ``--model`` names (before any
    heavy import)."""
    kind = planner_kind(args.model)
    if kind == "oracle":
        raise SystemExit(
            "error: --model oracle reads the simulator's state, which depth images do not "
            "hold: it plays only in symgrasp bench declutter"
        )
    if kind == "model":
        if args.gripper is not None:
            raise SystemExit(
                f"error: --gripper is for vgn and your own planner; --model {args.model} "
                "decides its own hand"
            )
        return
    model_only = {
        "--validity": args.validity is not None,
        "--confidence": args.confidence is not None,
        "--no-confidence": args.no_confidence,
        "--validity-floor": args.validity_floor is not None,
        "--fallbacks": args.fallbacks is not None,
        "--no-operating-point": args.no_operating_point,
        "--samples-per-voxel": args.samples_per_voxel != 0,
        "--fill-holes": args.fill_holes != 0,
        "--table-scale": args.table_scale,
        "--depth-scale": args.depth_scale is not None,
        "--approach-check": args.approach_check,
        "--optimize": args.optimize,
    }
    if kind == "plugin":
        model_only["--workspace-origin"] = any(args.workspace_origin)
        model_only["--device"] = args.device != "auto"
    given = [flag for flag, used in model_only.items() if used]
    if given:
        raise SystemExit(f"error: --model {args.model} takes no {', '.join(given)}")


def _planner(args: argparse.Namespace):
    """The planner ``--model`` names, with the options `_check_planner_options` let through."""
    kind = planner_kind(args.model)
    if kind == "model":
        return load_detector(args)
    from symgrasp.peers.planners import load_planner

    if kind == "plugin":
        import os

        if os.getcwd() not in sys.path:  # the planner's module, found as `python -m` finds it
            sys.path.insert(0, os.getcwd())
        return load_planner(args.model, args.gripper)
    from symgrasp.device import resolve_device

    return load_planner(
        args.model, args.gripper, str(resolve_device(args.device)),
        workspace_origin=tuple(args.workspace_origin),
    )  # fmt: skip


def _fused(planner, depth, intrinsic, extrinsic, origin):
    """The TSDF the pictures draw: the planner's own fusion where it has one, else
    symgrasp's."""
    from symgrasp.detect.detector import fuse

    if hasattr(planner, "fuse"):
        return planner.fuse(depth, intrinsic, extrinsic)
    return fuse(depth, intrinsic, extrinsic, origin)


def _add_export(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "export",
        help="strip a training checkpoint down to a shippable model, or export a TorchScript file",
        description="Copy a checkpoint written by `symgrasp train` without its optimizer state "
        "and, for a run with --ema, its trained weights next to the average (what symgrasp "
        "ships in symgrasp/detect/models/). With --torchscript, write the model's network as a "
        "frozen TorchScript graph that LibTorch (C++) or torch.jit.load runs without symgrasp, "
        "its input grid, representation, gripper and default thresholds stored inside "
        "(docs/detect.md, 'Exported model').",
    )
    parser.add_argument(
        "checkpoint",
        type=parse_model,
        metavar=MODEL_METAVAR,
        help="checkpoint path (e.g. runs/NAME/best.pt) or shipped model name",
    )
    parser.add_argument("out", type=output_path, help="output .pt path")
    parser.add_argument(
        "--torchscript",
        action="store_true",
        help="write the network as a TorchScript graph instead of a checkpoint",
    )
    parser.set_defaults(run=_run_export)


def _run_export(args: argparse.Namespace) -> None:
    from symgrasp.detect import export_model, export_torchscript
    from symgrasp.detect.pretrained import resolve_model

    if args.torchscript:
        print(export_torchscript(args.checkpoint, args.out))
    else:
        print(export_model(resolve_model(args.checkpoint), args.out))
