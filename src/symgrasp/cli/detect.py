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
from symgrasp.names import CUT_OBJECTS, planner_kind


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
    parser.add_argument(
        "--fit-table",
        action="store_true",
        help="with --depth: find the table in the image and place the workspace on it "
        "(symgrasp.perception.fit_table); the grasps then in the frame of --extrinsic, whose +z "
        "is taken for up, or in the camera's frame without it (docs/detect.md)",
    )
    scene = parser.add_mutually_exclusive_group()
    scene.add_argument(
        "--whole-table",
        action="store_true",
        help="with --depth: detect over the whole table, one workspace per group of objects on "
        "it (the table at --workspace-origin's z + 5 cm, or the fitted one with --fit-table), "
        "the grasps merged and ranked together (docs/detect.md)",
    )
    scene.add_argument(
        "--mask",
        type=input_file,
        help="with --depth: only the object of this mask, a .npy of booleans (or 0/1) or a .png "
        "(non-zero: the object) the size of the depth image; the workspace centred on it",
    )
    scene.add_argument(
        "--pixel",
        type=integer(0, 10**6),
        nargs=2,
        metavar=("U", "V"),
        help="with --depth: only the object seen at pixel (column U, row V); the workspace "
        "centred on it",
    )
    scene.add_argument(
        "--box",
        type=integer(0, 10**6),
        nargs=4,
        metavar=("U0", "V0", "U1", "V1"),
        help="with --depth: only the largest object inside this pixel box (corners inclusive); "
        "the workspace centred on it",
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
        "--cut-objects",
        choices=CUT_OBJECTS,
        default="flag",
        help="what to do with the grasps whose hand, approaching or closed, meets depth points "
        "above the workspace's top or past its sides, on an object the cube cuts: flag them "
        '("cut": true, the default), remove them, or ignore them; a warning says how many '
        "(docs/robot.md, 'Objects the cube cuts')",
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
        cut_objects=args.cut_objects,
        optimize=args.optimize,
    )


def _run_detect(args: argparse.Namespace) -> None:
    from symgrasp.folders import PICTURES, output_folder

    if args.depth is not None and (
        args.intrinsic is None or (args.extrinsic is None and not args.fit_table)
    ):
        raise ValueError("--depth needs --intrinsic and --extrinsic (its camera and pose) or "
                         "--fit-table")  # fmt: skip
    on_table = {**_scene_flags(args), "--fit-table": args.fit_table}
    asked = [flag for flag, used in on_table.items() if used]
    if asked and args.depth is None:
        raise ValueError(f"{asked[0]} goes with --depth, not with --points")
    if asked and planner_kind(args.model) != "model":
        raise ValueError(f"{asked[0]} needs a symgrasp model, not --model {args.model}")
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
    if args.fit_table or any(_scene_flags(args).values()):
        _detect_on_table(args, planner)
        return
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


def _scene_flags(args: argparse.Namespace) -> dict[str, bool]:
    return {
        "--whole-table": args.whole_table,
        "--mask": args.mask is not None,
        "--pixel": args.pixel is not None,
        "--box": args.box is not None,
    }


def _detect_on_table(args: argparse.Namespace, detector) -> None:
    """`_detect` with --fit-table, --whole-table, --mask, --pixel or --box: the grasps of
    `symgrasp.detect.scene` (or of the detector's cube on the fitted table) in the frame of
    --extrinsic (with --fit-table and none: the camera's), drawn over the image's points."""
    from types import SimpleNamespace

    import numpy as np

    from symgrasp.detect.files import load_depth, load_extrinsic, load_intrinsic, write_detection
    from symgrasp.detect.scene import detect_object, detect_table
    from symgrasp.perception import depth_to_points, fit_table

    depth = load_depth(args.depth, args.png_scale)
    intrinsic = load_intrinsic(args.intrinsic, depth.shape)
    T_frame_camera = np.eye(4) if args.extrinsic is None else load_extrinsic(args.extrinsic)
    T_frame_world = np.eye(4)  # the detector's world in the answer's frame
    T_world_camera = T_frame_camera
    if args.fit_table:
        up = None if args.extrinsic is None else T_frame_camera[:3, :3].T @ [0.0, 0.0, 1.0]
        fit = fit_table(depth, intrinsic, up=up)
        shift = np.eye(4)
        shift[:3, 3] = detector.origin
        T_world_camera = shift @ fit.T_workspace_camera  # the fitted cube at the origin
        T_frame_world = T_frame_camera @ np.linalg.inv(T_world_camera)
    with warnings.catch_warnings(record=True) as caught:  # one line each, as errors are
        warnings.simplefilter("always")
        if args.whole_table:
            grasps = detect_table(detector, depth, intrinsic, T_world_camera).grasps
        elif args.fit_table and not any(_scene_flags(args).values()):
            grasps = detector.detect(depth, intrinsic, T_world_camera)
        else:
            selection = {"pixel": args.pixel, "box": args.box}
            selection = {k: tuple(v) for k, v in selection.items() if v is not None}
            if args.mask is not None:
                selection["mask"] = _load_mask(args.mask)
            grasps = detect_object(detector, depth, intrinsic, T_world_camera, **selection).grasps
    for warning in caught:
        print(f"warning: {warning.message}", file=sys.stderr)
    grasps = [grasp.transformed(T_frame_world) for grasp in grasps[: args.top_k]]
    volume = _fused(detector, depth, intrinsic, T_world_camera, detector.origin)
    points = depth_to_points(depth, intrinsic, T_frame_camera, crop=False)
    # not the detector: its grasps are not all in this one volume's frame and grid, whose
    # closing-axis samples the pictures would draw
    drawn = SimpleNamespace(
        name=detector.name, version=detector.version, representation=detector.representation,
        gripper=detector.gripper, timing=detector.timing,
    )  # fmt: skip
    paths = write_detection(args.out, drawn, volume, grasps, points)
    found = f"{len(grasps)} grasps" if grasps else "no grasp found (the scene is drawn)"
    print(f"{found}; " + ", ".join(str(p) for p in paths.values()))


def _load_mask(path: str):  # -> np.ndarray (H, W)
    """The object mask of a ``.npy`` (booleans or 0/1: `detect_object` checks) or a ``.png``
    (non-zero: the object); ValueError naming the file otherwise."""
    from pathlib import Path

    import numpy as np
    from PIL import Image

    suffix = Path(path).suffix
    try:
        if suffix == ".npy":
            return np.load(path, allow_pickle=False)
        if suffix == ".png":
            image = np.asarray(Image.open(path))
            if image.ndim == 2:
                return image != 0
            raise ValueError(f"a mask .png has one channel, got shape {image.shape}")
    except (OSError, ValueError, EOFError) as error:
        raise ValueError(f"--mask: cannot read a mask from {path} ({error})") from None
    raise ValueError(f"--mask must be a .npy or .png file, got {path}")


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
        "--cut-objects": args.cut_objects != "flag",
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
    from symgrasp.config import PlannerOptions
    from symgrasp.peers.planners import load_planner

    if kind == "plugin":
        import os

        if os.getcwd() not in sys.path:  # the planner's module, found as `python -m` finds it
            sys.path.insert(0, os.getcwd())
        return load_planner(args.model, PlannerOptions(gripper=args.gripper))
    from symgrasp.device import resolve_device

    options = PlannerOptions(gripper=args.gripper, workspace_origin=tuple(args.workspace_origin))
    return load_planner(args.model, options, str(resolve_device(args.device)))


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
