"""The ``symgrasp`` command: one sub-command per job, each a thin wrapper over the package.

A job's options are built from its configuration (`symgrasp.config`): every field is an
option and its documentation is the option's help, so a new field is on the command line
without an edit here. The options several commands share (``--objects``, ``--gripper``,
``--rep``, the confidence pair) are defined once below, with their choices from
`symgrasp.names`. Building the parser imports no heavy package (``symgrasp --help`` answers
without torch or MuJoCo); each command's run function imports what it needs.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import shlex
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, NoReturn

from symgrasp.config import (
    DEFAULT_VALIDITY,
    MAX_OBJECTS,
    MAX_WORKERS,
    SEED_MAX,
    TEST_SEED_LIMIT,
    VALIDATION_OBJECTS,
    VALIDATION_ROUNDS,
    VALIDATION_SEED,
    BenchmarkConfig,
    ParallelConfig,
    SceneConfig,
    TrainConfig,
)
from symgrasp.fields import field_docs
from symgrasp.names import (
    BACKENDS,
    GRIPPER_SPEC_SUFFIX,
    GRIPPERS,
    MESH_OBJECT_SETS,
    MESH_UNITS,
    OBJECT_SETS,
    PRETRAINED,
    REPRESENTATIONS,
    SCENES,
    SCHEDULES,
    VALIDITY_LOSSES,
)
from symgrasp.objects.folder import data_folder
from symgrasp.parallel import TasksFailed
from symgrasp.workspace import WORKSPACE_SIZE

# -- options shared between commands ------------------------------------------------------


def _object_set(value: str) -> str:
    """An object set's name, an existing folder, or mesh sets and folders joined by commas
    (read and checked when the command runs)."""
    parts = value.split(",")
    if value in OBJECT_SETS or all(
        p in MESH_OBJECT_SETS or Path(p).expanduser().is_dir() for p in parts
    ):
        return value
    raise argparse.ArgumentTypeError(
        f"expected one of {', '.join(OBJECT_SETS)} (mesh sets are read from the data folder "
        f"{data_folder()}), a folder of URDF files or meshes, or mesh sets and folders joined "
        f"by commas, got {value!r}"
    )


def _gripper(value: str) -> str:
    """A built-in gripper's name or an existing .toml spec file (read and checked when the
    command runs)."""
    if value in GRIPPERS or (value.lower().endswith(GRIPPER_SPEC_SUFFIX) and Path(value).is_file()):
        return value
    raise argparse.ArgumentTypeError(
        f"expected one of {', '.join(GRIPPERS)} or an existing .toml gripper spec file "
        f"(docs/sim.md), got {value!r}"
    )


GRIPPER_METAVAR = "{" + ",".join(GRIPPERS) + "}|SPEC" + GRIPPER_SPEC_SUFFIX
"""How ``--gripper``'s value is shown in every help."""

MODEL_METAVAR = "{" + ",".join(PRETRAINED) + "}|CHECKPOINT"
"""How ``--model``'s value is shown in every help: a shipped model's name or a file."""

SHARED = {
    "objects": ("--objects", {"type": _object_set, "metavar": "SET|FOLDER"}),
    "object_set": ("--objects", {"type": _object_set, "metavar": "SET|FOLDER"}),
    "scene": ("--scene", {"choices": SCENES}),
    "gripper": ("--gripper", {"type": _gripper, "metavar": GRIPPER_METAVAR}),
    "model": ("--model", {"metavar": MODEL_METAVAR}),
    "representation": ("--rep", {"choices": REPRESENTATIONS}),
    "kinds": ("--kinds", {"choices": SCENES}),
    "mesh_unit": ("--mesh-unit", {"choices": MESH_UNITS}),
    "schedule": ("--schedule", {"choices": SCHEDULES}),
    "validity.kind": ("--validity-loss", {"choices": VALIDITY_LOSSES}),
}
"""How a field of these names (a nested one also by its path) appears on any command line: its
flag and its choices."""


def _add_shared(parser: argparse.ArgumentParser, name: str, help: str, default: Any = None) -> None:
    """The shared option ``name`` (a key of `SHARED`) with its flag and choices."""
    flag, options = SHARED[name]
    parser.add_argument(flag, dest=name, default=default, help=help, **options)


def _add_mesh_unit(parser: argparse.ArgumentParser) -> None:
    """``--mesh-unit``, as `SceneConfig.mesh_unit` documents it, on a command without a
    configuration."""
    help = _sentence(field_docs(SceneConfig)["mesh_unit"])
    _add_shared(parser, "mesh_unit", f"{help} (default: auto)", "auto")


def _add_confidence_options(parser: argparse.ArgumentParser) -> None:
    group = parser.add_mutually_exclusive_group()
    group.add_argument(
        "--confidence",
        type=_number(0.0, 1e6),
        default=None,
        help="Bingham confidence threshold (default: 15 for bingham2d, none otherwise)",
    )
    group.add_argument(
        "--no-confidence",
        action="store_true",
        help="turn the confidence threshold off (the paper's 'without threshold' ablation)",
    )


def _confidence_threshold(args: argparse.Namespace) -> float | None:
    """``GraspDetector``'s ``confidence_threshold`` from ``--confidence``/``--no-confidence``."""
    return 0.0 if args.no_confidence else args.confidence


def _integer(lo: int, hi: int) -> Callable[[str], int]:
    """An argparse type: an integer in [lo, hi]."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = None
        if value is None or not lo <= value <= hi:
            raise argparse.ArgumentTypeError(f"must be an integer in [{lo}, {hi}], got {text!r}")
        return value

    return parse


def _number(lo: float, hi: float) -> Callable[[str], float]:
    """An argparse type: a finite number in [lo, hi]."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not lo <= value <= hi:  # NaN fails too
            raise argparse.ArgumentTypeError(f"must be a number in [{lo:g}, {hi:g}], got {text!r}")
        return value

    return parse


SEED = _integer(0, SEED_MAX)
PROBABILITY = _number(0.0, 1.0)


def add_parallel_options(parser: argparse.ArgumentParser, tasks: str) -> None:
    """``--backend``, ``--workers`` and ``--ray-address`` (`ParallelConfig`) for a command whose
    pure tasks are ``tasks`` (e.g. "rounds")."""
    docs = field_docs(ParallelConfig)
    parser.add_argument(
        "--backend", choices=BACKENDS, default="process",
        help=f"where the {tasks} run: {_sentence(docs['backend'])} (default: process)",
    )  # fmt: skip
    parser.add_argument(
        "--workers", type=_integer(1, MAX_WORKERS), default=None,
        help=f"{_sentence(docs['workers'])}",
    )  # fmt: skip
    parser.add_argument(
        "--ray-address", default=None, metavar="HOST:PORT", help=_sentence(docs["ray_address"])
    )


def parallel_from_args(args: argparse.Namespace) -> ParallelConfig:
    """The `ParallelConfig` of `add_parallel_options`' options."""
    return ParallelConfig(args.backend, args.workers, args.ray_address)


# -- options from a configuration's fields ------------------------------------------------

_SCALARS: dict[str, Callable[[str], Any]] = {"int": int, "float": float, "str": str}


def _value_options(annotation: str) -> dict[str, Any]:
    """argparse keywords for a field annotated ``annotation`` (as written in the source)."""
    base = annotation.removesuffix(" | None")
    if base == "bool":
        return {"action": argparse.BooleanOptionalAction}
    if base in _SCALARS:
        return {"type": _SCALARS[base]}
    if base.startswith("tuple[") and base.endswith("]"):
        items = [item.strip() for item in base[len("tuple[") : -1].split(",")]
        nargs: int | str = "+" if items[-1] == "..." else len(items)
        return {"type": _SCALARS[items[0]], "nargs": nargs}
    raise TypeError(f"no command-line form for a field of type {annotation}")


def _sentence(doc: str) -> str:
    """A field's documentation as an option's help: lower case, no final full stop."""
    if len(doc) > 1 and doc[0].isupper() and doc[1].islower():
        doc = doc[0].lower() + doc[1:]
    return doc.removesuffix(".").replace("%", "%%")


def _shown(default: Any) -> str:
    if isinstance(default, tuple):
        return " ".join(_shown(v) for v in default)
    return f"{default:g}" if isinstance(default, float) else str(default)


def add_config_options(
    parser: argparse.ArgumentParser,
    cls: type,
    skip: Sequence[str] = (),
    prefixes: dict[str, str] | None = None,
    path: str = "",
) -> None:
    """One option per field of the dataclass ``cls`` (nested dataclasses: one per field of
    theirs, flags prefixed by ``prefixes[field]``); dests are the fields' dotted paths."""
    prefixes = prefixes or {}
    docs = field_docs(cls)
    for f in dataclasses.fields(cls):
        if f.name in skip:
            continue
        dest = path + f.name
        if f.default_factory is not dataclasses.MISSING:
            nested = f.default_factory()
            prefix = prefixes.get(f.name, "")
            add_config_options(parser, type(nested), (), {}, f"{dest}.{prefix}")
            continue
        flag, options = SHARED.get(dest, SHARED.get(f.name, (None, {})))
        name = dest.split(".")[-1]
        flag = flag or "--" + name.replace("_", "-")
        options = {**_value_options(str(f.type)), **options}
        if "choices" not in options and "action" not in options:
            options.setdefault("metavar", name.upper())
        help = _sentence(docs[f.name])
        if f.default is dataclasses.MISSING:
            parser.add_argument(flag, dest=dest, required=True, help=help, **options)
            continue
        if isinstance(f.default, bool):
            help += f" (default: {'on' if f.default else 'off'})"
        elif f.default is not None:
            help += f" (default: {_shown(f.default)})"
        parser.add_argument(flag, dest=dest, default=f.default, help=help, **options)


def config_from_args(
    cls: type, args: argparse.Namespace, path: str = "", prefixes: dict[str, str] | None = None
) -> Any:
    """The ``cls`` whose fields `add_config_options` put on the command line, from ``args``;
    fields it skipped keep their defaults."""
    prefixes = prefixes or {}
    values = {}
    for f in dataclasses.fields(cls):
        dest = path + f.name
        if f.default_factory is not dataclasses.MISSING:
            nested = type(f.default_factory())
            values[f.name] = config_from_args(
                nested, args, f"{dest}.{prefixes.get(f.name, '')}", {}
            )
        elif hasattr(args, dest):
            value = getattr(args, dest)
            values[f.name] = tuple(value) if isinstance(value, list) else value
    return cls(**values)


# -- demo ---------------------------------------------------------------------------------


def _add_demo(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "demo",
        help="the main job of `make demo`: the shipped detector clears a simulated pile",
        description="Drop a random pile of objects in the MuJoCo world, then repeatedly render "
        "one depth image, detect grasps with a shipped model and execute the best "
        "collision-free one, until the table is clear or two grasps fail in a row. Prints "
        "every attempt and the round's success and clear ratios; writes a picture per attempt, "
        "demo.html and summary.json into --out.",
    )
    parser.add_argument("--out", default="out/demo", help="output folder (default: out/demo)")
    parser.add_argument(
        "--seed", type=SEED, default=0, help="seed of the objects and the pile (default: 0)"
    )
    _add_shared(
        parser,
        "gripper",
        "gripper: a built-in's name, whose shipped bingham2d model is used, or a spec file "
        "(then --model is needed) (default: robotiq-2f85)",
        "robotiq-2f85",
    )
    _add_shared(parser, "objects", "object set (default: household-test)", "household-test")
    parser.add_argument(
        "--num-objects",
        type=_integer(1, MAX_OBJECTS),
        default=5,
        help="objects dropped on the table (default: 5)",
    )
    parser.add_argument(
        "--model",
        default=None,
        metavar=MODEL_METAVAR,
        help="another shipped model or a checkpoint path instead of the gripper's bingham2d model",
    )
    _add_mesh_unit(parser)
    parser.set_defaults(run=_run_demo)


def _run_demo(args: argparse.Namespace) -> None:
    from symgrasp.demo import run_demo

    run_demo(
        args.out, args.seed, args.gripper, args.objects, args.num_objects, args.model,
        args.mesh_unit,
    )  # fmt: skip


# -- detect and export --------------------------------------------------------------------


def _add_detect(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "detect",
        help="detect grasps in a depth image",
        description="Fuse a depth image into the workspace TSDF, run a grasp detector and write "
        "grasps.json (T_world_tcp, scores, confidences; best first), grasps.png (points and the "
        "top grasps coloured by score) and grasps.html (interactive 3-D view) into --out. The "
        "workspace is the 30 cm cube from --workspace-origin, with the table 5 cm above its "
        "floor, as in training.",
    )
    parser.add_argument(
        "--depth",
        required=True,
        help="depth image: .npy in metres, or a 16-bit .png in units of --png-scale",
    )
    parser.add_argument(
        "--intrinsic",
        required=True,
        help='JSON: {"fx", "fy", "cx", "cy"[, "width", "height"]} or a 3×3 matrix',
    )
    parser.add_argument(
        "--extrinsic", required=True, help="JSON: the 4×4 camera pose T_world_camera [m]"
    )
    parser.add_argument(
        "--model",
        default="bingham2d-robotiq-2f85",
        metavar=MODEL_METAVAR,
        help="shipped model name or checkpoint path (default: bingham2d-robotiq-2f85)",
    )
    parser.add_argument("--out", required=True, help="output folder")
    parser.add_argument(
        "--png-scale",
        type=_number(1e-9, 1e3),
        default=0.001,
        help="metres per PNG unit (default: 0.001)",
    )
    parser.add_argument(
        "--workspace-origin",
        type=_number(-1e3, 1e3),
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
    _add_confidence_options(parser)
    parser.add_argument(
        "--top-k", type=_integer(1, 10**6), default=None, help="keep the best K grasps"
    )
    parser.add_argument(
        "--samples-per-voxel",
        type=_integer(0, 1000),
        default=0,
        help="draw N closing axes per voxel from the Bingham output (default: 0, the mode)",
    )
    parser.add_argument("--device", default="auto", help="auto, cpu or cuda (default: auto)")
    parser.set_defaults(run=_run_detect)


def _run_detect(args: argparse.Namespace) -> None:
    from symgrasp.atomic import check_folder
    from symgrasp.detect import GraspDetector
    from symgrasp.detect.files import load_depth, load_extrinsic, load_intrinsic, write_detection
    from symgrasp.perception import depth_to_points

    check_folder(args.out, "--out")
    depth = load_depth(args.depth, args.png_scale)
    intrinsic = load_intrinsic(args.intrinsic, depth.shape)
    extrinsic = load_extrinsic(args.extrinsic)
    detector = GraspDetector.from_pretrained(
        args.model,
        device=args.device,
        validity_threshold=args.validity,
        confidence_threshold=_confidence_threshold(args),
        top_k=args.top_k,
        samples_per_voxel=args.samples_per_voxel,
        workspace_origin=tuple(args.workspace_origin),
    )
    volume = detector.fuse(depth, intrinsic, extrinsic)
    grasps = detector.detect_tsdf(volume.grid())
    points = depth_to_points(depth, intrinsic, extrinsic)
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
    parser.add_argument("checkpoint", help="checkpoint path, e.g. runs/NAME/best.pt")
    parser.add_argument("out", help="output .pt path")
    parser.set_defaults(run=_run_export)


def _run_export(args: argparse.Namespace) -> None:
    from symgrasp.detect import export_model

    print(export_model(args.checkpoint, args.out))


# -- sim ----------------------------------------------------------------------------------


def _add_objects(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "objects",
        help="object sets: download VGN's, look inside one",
        description="Object sets on disk: VGN's household meshes in the data folder "
        "($SYMGRASP_DATA, default ~/.cache/symgrasp), a folder of URDF files or a folder of "
        "bare OBJ/STL/PLY meshes (cut into convex parts once, cached in <data>/cache).",
    )
    actions = parser.add_subparsers(
        dest="action", required=True, metavar="ACTION", help="what to do (fetch, inspect)"
    )
    fetch = actions.add_parser(
        "fetch",
        help="download VGN's household object sets into the data folder",
        description="Download VGN's object sets (pile/packed, train/test; Breyer et al. 2020, "
        "as redistributed by the MIT-licensed HaojHuang/Edge-Grasp-Network at a pinned "
        "commit) into <data>/objects/vgn. Every file is checked against the manifest shipped "
        "with symgrasp; a killed download continues where it stopped; nothing is put in "
        "place until all of it is there and checked. Does nothing when the sets are there.",
    )
    fetch.add_argument("what", choices=("vgn",), help="what to download (vgn: VGN's four sets)")
    fetch.add_argument(
        "--data", default=None,
        help="data folder to download into (default: $SYMGRASP_DATA, else ~/.cache/symgrasp)",
    )  # fmt: skip
    fetch.add_argument(
        "--url", default=None,
        help="archive to download instead of the pinned GitHub one: a mirror, or a file:// "
        "URL of a copy; its files must still match the shipped manifest",
    )  # fmt: skip
    fetch.set_defaults(run=_run_objects_fetch)
    inspect = actions.add_parser(
        "inspect",
        help="print what a set holds and draw it",
        description="Print, per object: its units (a bare mesh's as read, guessed or given "
        "by --mesh-unit; a URDF's as its size suggests), its size, mass, convex parts (MuJoCo "
        "collides each as one convex geom) and whether its mesh (a URDF's visual mesh) is "
        "watertight, and every file refused and why; then draw the first objects' collision "
        "parts into one picture.",
    )
    inspect.add_argument("objects", type=_object_set, metavar="SET|FOLDER",
                         help="a mesh set's name (vgn-pile-test, …), a folder of URDF files or "
                         "bare OBJ/STL/PLY meshes, or several joined by commas")  # fmt: skip
    inspect.add_argument(
        "--out", default=None, help="picture to write (default: out/objects/<set>.png)"
    )
    inspect.add_argument(
        "--limit", type=_integer(1, 500), default=48, help="objects drawn (default: 48)"
    )
    _add_mesh_unit(inspect)
    inspect.set_defaults(run=_run_objects_inspect)


def _run_objects_fetch(args: argparse.Namespace) -> None:
    from symgrasp.objects.fetch import VGN_ARCHIVE_URL, fetch_vgn

    print(f"VGN's object sets are in {fetch_vgn(args.data, args.url or VGN_ARCHIVE_URL)}")


def _run_objects_inspect(args: argparse.Namespace) -> None:
    from symgrasp.objects.inspect import HEADER, contact_sheet, inspect_objects
    from symgrasp.objects.sets import resolve

    source = resolve(args.objects, args.mesh_unit)
    if not source.meshes:
        raise SystemExit(f"error: {args.objects} is built in code, not read from meshes")
    reports, refused = inspect_objects(source)
    where = ", ".join(map(str, source.folders))
    print(f"{len(reports)} objects in {where}, {len(refused)} refused")
    print(HEADER)
    for report in reports:
        print(report.row())
    for reason in refused:
        print(f"refused: {reason}")
    out = args.out or f"out/objects/{Path(args.objects).name}.png"
    print(f"picture: {contact_sheet(source, out, args.limit)}")


def _add_sim(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "sim",
        help="look at the simulated world",
        description="Tools around the MuJoCo world of symgrasp.sim.",
    )
    actions = parser.add_subparsers(
        dest="action", required=True, metavar="ACTION", help="what to do (show)"
    )
    show = actions.add_parser(
        "show",
        help="write pictures of a scene",
        description="Build and settle a scene, then write a colour view (OpenGL render, or a "
        "matplotlib fallback without GL) and the depth image from the default camera.",
    )
    show.add_argument("--scene", choices=SCENES, default="pile", help="scene kind (default: pile)")
    _add_shared(
        show, "objects", "object set to draw from (default: household-train)",
        "household-train",
    )  # fmt: skip
    show.add_argument(
        "--n", type=_integer(1, MAX_OBJECTS), default=5, help="number of objects (default: 5)"
    )
    show.add_argument("--seed", type=SEED, default=0, help="random seed (default: 0)")
    show.add_argument("--out", default="out/sim", help="output folder (default: out/sim)")
    _add_mesh_unit(show)
    show.set_defaults(run=_run_sim_show)


def _run_sim_show(args: argparse.Namespace) -> None:
    from symgrasp.objects.sets import resolve
    from symgrasp.sim import make_scene
    from symgrasp.sim.show import save_scene_pictures

    source = resolve(args.objects, args.mesh_unit)
    world = make_scene(args.scene, source, n=args.n, seed=args.seed)
    stem = f"{args.scene}_{Path(args.objects).name}_seed{args.seed}"
    paths, renderer = save_scene_pictures(world, args.out, stem)
    print(f"{len(world.objects)} objects settled: {', '.join(o.name for o in world.objects)}")
    print(f"depth renderer: {renderer}")
    for kind, path in paths.items():
        print(f"{kind}: {path}")


def _add_gripper(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "gripper",
        help="look at a gripper: a built-in or your own spec file",
        description="A gripper is a small TOML spec file (docs/sim.md, 'Your own gripper'); "
        "the built-in ones are shipped as such files.",
    )
    actions = parser.add_subparsers(
        dest="action", required=True, metavar="ACTION", help="what to do (show)"
    )
    show = actions.add_parser(
        "show",
        help="draw a gripper open and closed",
        description="Check a gripper's spec, build its simulated hand, close it on nothing and "
        "draw its boxes (those the swept-hand collision check uses) open and closed, from the "
        "side and from the front, with its dimensions annotated and its spec listed.",
    )
    show.add_argument(
        "spec", type=_gripper, metavar=GRIPPER_METAVAR, help="a built-in's name or a spec file"
    )
    show.add_argument("--out", default=None, help="picture path (default: out/gripper/<name>.png)")
    show.set_defaults(run=_run_gripper_show)


def _run_gripper_show(args: argparse.Namespace) -> None:
    from symgrasp.sim.grippers import get_gripper
    from symgrasp.sim.show import save_gripper_png

    spec = get_gripper(args.spec)
    path = save_gripper_png(spec, args.out or f"out/gripper/{spec.name}.png")
    print(f"{spec.name} ({spec.kind}): opening {spec.max_width * 1000:g} mm, finger depth "
          f"{spec.finger_depth * 1000:.1f} mm, pads {spec.pad_width * 1000:g} mm wide, "
          f"{spec.grip_force:g} N; picture: {path}")  # fmt: skip


# -- data ---------------------------------------------------------------------------------


def _add_data(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "data",
        help="generate and inspect grasp datasets",
        description="Per-object grasp databases, labelled cluttered scenes, dataset cards "
        "(docs/data.md).",
    )
    actions = parser.add_subparsers(
        dest="action", required=True, metavar="ACTION", help="what to do (generate, inspect, show)"
    )
    gen = actions.add_parser(
        "generate",
        help="write a labelled dataset",
        description="Build (or reuse) the grasp database of every pool object, then write "
        "labelled scenes as one compressed file each, atomically; --resume continues an "
        "interrupted run. Every field of the dataset's configuration (symgrasp.config."
        "SceneConfig, and its DatabaseConfig) is an option.",
    )
    gen.add_argument("--out", required=True, help="dataset folder")
    gen.add_argument(
        "--scenes", type=_integer(1, 10**7), default=2000, help="number of scenes (default: 2000)"
    )
    gen.add_argument("--seed", type=SEED, default=0, help="dataset seed (default: 0)")
    add_parallel_options(gen, "databases and scenes")
    gen.add_argument(
        "--resume", action="store_true", help="continue a run in --out, skipping written scenes"
    )
    add_config_options(gen, SceneConfig)
    gen.set_defaults(run=_run_data_generate)

    inspect = actions.add_parser(
        "inspect",
        help="print counts and write the dataset card",
        description="Print counts, class balance and score histograms of a dataset and write "
        "card.json and card.png into it.",
    )
    inspect.add_argument("root", help="dataset folder")
    inspect.add_argument(
        "--validate",
        type=_integer(0, 100_000),
        default=50,
        help="physics trials of labelled vs random grasps for the card; 0 skips them (default: 50)",
    )
    inspect.add_argument("--seed", type=SEED, default=0, help="seed of the trials (default: 0)")
    inspect.set_defaults(run=_run_data_inspect)

    show = actions.add_parser(
        "show",
        help="draw one scene",
        description="Draw a scene's TSDF surface, its labelled grasps and its depth image.",
    )
    show.add_argument("root", help="dataset folder")
    show.add_argument("--scene", type=_integer(0, 10**7), default=0, help="scene id (default: 0)")
    show.add_argument("--out", default=None, help="picture path (default: ROOT/scene_<id>.png)")
    show.set_defaults(run=_run_data_show)


def _run_data_generate(args: argparse.Namespace) -> None:
    from symgrasp.data.generate import generate

    config = config_from_args(SceneConfig, args)
    manifest = generate(
        args.out, config, args.scenes, args.seed, args.resume, parallel_from_args(args)
    )
    print(f"{manifest['num_scenes']} scenes in {args.out} (hash {manifest['dataset_hash']})")


def _run_data_inspect(args: argparse.Namespace) -> None:
    import json

    from symgrasp.data.card import dataset_card

    print(json.dumps(dataset_card(args.root, args.validate, args.seed), indent=1))


def _run_data_show(args: argparse.Namespace) -> None:
    from symgrasp.data.card import show_scene

    print(show_scene(args.root, args.scene, args.out))


# -- figures ------------------------------------------------------------------------------


def _command(*words: object) -> str:
    """The shell command that reproduces a run, recorded next to its results."""
    return shlex.join(["symgrasp", *(str(w) for w in words)])


def _add_figures(subparsers: argparse._SubParsersAction) -> None:
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
        type=_integer(1, 10**7),
        default=1_000_000,
        help="Bingham draws per Monte-Carlo estimate (default: 1000000)",
    )
    percentiles.add_argument(
        "--repeats",
        type=_integer(1, 10_000),
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
        "--out", default="docs/figures", help="output folder (default: docs/figures)"
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
        required=True,
        metavar=MODEL_METAVAR,
        help="checkpoint path or shipped model name (a Bingham model)",
    )
    distribution.add_argument(
        "--samples", type=_integer(1, 1000), default=30, help="e_z drawn per voxel (default: 30)"
    )
    distribution.add_argument("--seed", type=SEED, default=0, help="sampling seed (default: 0)")
    _add_slice_options(distribution)
    distribution.set_defaults(run=_run_distribution)


def _height(text: str) -> float | None:
    """``--height``: metres inside the workspace, or None for 'auto'."""
    return None if text == "auto" else _number(0.0, WORKSPACE_SIZE)(text)


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
        "--out", default="docs/figures", help="output folder (default: docs/figures)"
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


# -- train --------------------------------------------------------------------------------

_TRAIN_PREFIXES = {"loss_weights": "weight_"}
"""``--weight-validity`` etc. for the loss weights."""


def _add_train(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "train",
        help="train a grasp detection network",
        description="Train the volumetric grasp detector (symgrasp.model) on a dataset written "
        "by symgrasp.data. Writes last.pt, best.pt, metrics.csv and learning_curve.png into "
        "--out; validates on the held-out split after every epoch. Same seed, same result. "
        "Every field of the run's configuration (symgrasp.config.TrainConfig) is an option.",
    )
    add_config_options(parser, TrainConfig, prefixes=_TRAIN_PREFIXES)
    parser.add_argument(
        "--nproc", type=_integer(1, 1024), default=1,
        help="training processes on this machine, data-parallel (DistributedDataParallel: gloo "
        "on CPU, NCCL on GPU; as torchrun --nproc-per-node N -m symgrasp train does); "
        "--batch-size is the global batch, split evenly (default: 1)",
    )  # fmt: skip
    parser.set_defaults(run=_run_train)


def _run_train(args: argparse.Namespace) -> None:
    from symgrasp.model.train import train

    config = config_from_args(TrainConfig, args, prefixes=_TRAIN_PREFIXES)
    if args.nproc > 1:
        from symgrasp.model.distributed import check_global_batch, launch

        check_global_batch(config.batch_size, args.nproc)  # before the processes start
        launch(train, (config,), args.nproc)
        print(f"{config.epochs} epochs on {args.nproc} processes; checkpoints and metrics in "
              f"{config.out}")  # fmt: skip
        return
    history = train(config)
    print(f"{len(history)} epochs; checkpoints and metrics in {config.out}")


# -- select -------------------------------------------------------------------------------


def _add_select(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "select",
        help="choose a run's best.pt among its kept checkpoints by a validation measure",
        description="Evaluate every kept checkpoint of a training run (RUN_DIR/epoch_NNN.pt, "
        "and last.pt when its epoch has no file of its own), choose the best by --by and copy "
        "it to RUN_DIR/best.pt, recording the measure in it (a best.pt that training chose by "
        "validation loss is kept once as best_val_loss.pt). Writes RUN_DIR/selection.csv and "
        "selection.json (every measure of every checkpoint: its metrics.csv row and the "
        "declutter validation's numbers, where run). Results are cached per checkpoint in "
        "RUN_DIR/selection/, so a rerun skips finished checkpoints and resumes an interrupted "
        "declutter validation. The declutter validation plays training objects with seeds "
        f"from {VALIDATION_SEED}: test object sets and seeds below {TEST_SEED_LIMIT} (the test "
        "benchmarks') are refused (docs/model.md, 'Model selection').",
    )
    parser.add_argument(
        "run_dir", metavar="RUN_DIR", help="run folder of symgrasp train (its --out)"
    )
    parser.add_argument(
        "--by", required=True, metavar="MEASURE",
        help="declutter (the declutter validation's success ratio plus clear ratio; "
        "declutter_sr the success ratio alone, declutter_cr the clear ratio), val_loss, or a "
        "column of RUN_DIR/metrics.csv: higher is better for validity_ap, the top-k shares "
        "(top1_valid, top5_correct, …) and the declutter measures, lower for losses (val_*), "
        "score_mae, angles (*_deg) and top_empty",
    )  # fmt: skip
    _add_shared(
        parser, "objects",
        "object set of the declutter validation: training objects; a test set is refused "
        f"(default: {VALIDATION_OBJECTS})", VALIDATION_OBJECTS,
    )  # fmt: skip
    parser.add_argument(
        "--rounds", type=_integer(1, 100_000), default=VALIDATION_ROUNDS,
        help=f"declutter validation rounds per checkpoint (default: {VALIDATION_ROUNDS})",
    )  # fmt: skip
    parser.add_argument(
        "--seed", type=SEED, default=VALIDATION_SEED,
        help="seed of the declutter validation's round 0; round r uses seed + r; seeds below "
        f"{TEST_SEED_LIMIT} are the test benchmarks' and refused (default: {VALIDATION_SEED})",
    )  # fmt: skip
    parser.add_argument(
        "--num-objects", type=_integer(1, MAX_OBJECTS), default=5,
        help="objects per declutter validation round (default: 5)",
    )  # fmt: skip
    parser.add_argument(
        "--scene", choices=SCENES, default="pile",
        help="layout of the declutter validation's rounds (default: pile)",
    )  # fmt: skip
    _add_mesh_unit(parser)
    add_parallel_options(parser, "declutter validation rounds")
    parser.add_argument(
        "--revalidate", action="store_true",
        help="recompute each checkpoint's validation losses and metrics on the validation "
        "split instead of reading metrics.csv (for metrics added after the run trained, e.g. "
        "the top-k ones; cached like the declutter validation)",
    )  # fmt: skip
    parser.add_argument(
        "--data", default=None,
        help="dataset folder whose validation split --revalidate uses (default: the one the "
        "run trained on)",
    )  # fmt: skip
    parser.add_argument(
        "--batch-size", type=_integer(1, 4096), default=None,
        help="scenes per batch of --revalidate (default: the run's; on the dataset the run "
        "trained on, --revalidate also validates on its --val-scenes with its validity loss, "
        "so that metrics.csv's values come back)",
    )  # fmt: skip
    parser.add_argument(
        "--device",
        default="auto",
        help="where --revalidate runs: auto, cpu or cuda (default: auto)",
    )
    parser.add_argument(
        "--dry-run", action="store_true",
        help="write selection.csv and selection.json but leave best.pt as it is",
    )  # fmt: skip
    parser.set_defaults(run=_run_select)


def _run_select(args: argparse.Namespace) -> None:
    from symgrasp.benchmark.selection import DeclutterValidation, Revalidation, select_checkpoint

    validation = DeclutterValidation(
        objects=args.objects, rounds=args.rounds, seed=args.seed, num_objects=args.num_objects,
        scene=args.scene, mesh_unit=args.mesh_unit,
    )  # fmt: skip
    revalidate = Revalidation(args.data, batch_size=args.batch_size, device=args.device)
    selection = select_checkpoint(
        args.run_dir, args.by, validation=validation, parallel=parallel_from_args(args),
        revalidate=revalidate if args.revalidate else None, copy=not args.dry_run,
    )  # fmt: skip
    measure = selection["by"]
    for row in selection["checkpoints"]:
        extra = "".join(
            f"  {key} {row[key]:.3f}"
            for key in ("declutter_sr_cr", "declutter_sr", "declutter_cr")
            if key != measure and isinstance(row.get(key), float)
        ) + (f"  grasps {row['declutter_grasps']}" if "declutter_grasps" in row else "")
        value = row.get(measure)
        shown = f"{value:.4g}" if isinstance(value, int | float) else "—"
        print(f"{row['checkpoint']:>16}  epoch {row['epoch']:>4}  {measure} {shown}{extra}")
    chosen = selection["chosen"]
    where = "selection.csv and selection.json" + ("" if args.dry_run else "; best.pt")
    print(
        f"chosen: {chosen['checkpoint']} (epoch {chosen['epoch']}, {measure} "
        f"{chosen['value']:.4g}, {selection['better']} is better); {where} in {args.run_dir}"
    )


# -- bench --------------------------------------------------------------------------------


def _add_bench(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "bench",
        help="benchmarks of trained detectors",
        description="Benchmarks of trained detectors (symgrasp.benchmark).",
    )
    actions = parser.add_subparsers(
        dest="action", required=True, metavar="ACTION", help="what to run (declutter, compare)"
    )
    declutter = actions.add_parser(
        "declutter",
        help="simulated decluttering: success and clear ratios",
        description="VGN's and the paper's declutter protocol: each round drops --num-objects "
        "objects as a pile; before every attempt one depth image is fused, and the detector's "
        "best grasp whose approach misses the observed scene is executed; a round ends when "
        "the table is clear, no grasp is found or two attempts in a row fail. Round r uses seed "
        "--seed + r. Writes config.json, rounds.jsonl (each round as it finishes, so "
        "--resume can finish an interrupted run), then results.json (SR, CR with bootstrap "
        "95%% intervals over rounds, outcomes, failure modes, planning time) and results.md "
        "into --out. Each failed grasp is replayed from the state it started in, turned about "
        "its approach axis by 30..150 degrees: if a turn succeeds the failure was a wrong yaw, "
        "otherwise it is named by how it ended (collision, wrong approach = closed on nothing, "
        "slip).",
    )
    declutter.add_argument("--out", required=True, help="output folder")
    declutter.add_argument(
        "--resume",
        action="store_true",
        help="finish the run in --out: play only the rounds missing from its rounds.jsonl "
        "(refused if --out holds a run of another configuration)",
    )
    add_parallel_options(declutter, "rounds")
    add_config_options(declutter, BenchmarkConfig, skip=("options",))
    _add_confidence_options(declutter)
    declutter.add_argument(
        "--validity",
        type=PROBABILITY,
        default=None,
        help=f"validity threshold (default: {DEFAULT_VALIDITY}; a sweep per model: docs/results.md)",
    )
    _add_shared(
        declutter,
        "representation",
        "refuse to run unless --model uses this rotation representation (a guard for scripts: "
        "the checkpoint, not this option, decides the representation)",
    )
    _add_shared(
        declutter,
        "gripper",
        "refuse to run unless --model was trained for this gripper, a built-in's name or a spec "
        "file (the model's gripper, stored in it, is the one simulated)",
    )
    declutter.set_defaults(run=_run_declutter)
    compare = actions.add_parser(
        "compare",
        help="the paired change of SR and CR between two benchmarks of the same rounds",
        description="Compare two `bench declutter` folders on the rounds both finished (the same "
        "seeds drop the same objects the same way): SR and CR of each and A − B with a 95%% "
        "interval from one bootstrap over rounds resampled in pairs. The folders must play the "
        "same world (objects, mesh units, scene, objects per round); the models, thresholds and "
        "hands may differ.",
    )
    compare.add_argument("a", help="benchmark folder A")
    compare.add_argument("b", help="benchmark folder B (the baseline)")
    compare.set_defaults(run=_run_compare)


def _run_compare(args: argparse.Namespace) -> None:
    from symgrasp.benchmark.compare import compare_table

    print(compare_table(args.a, args.b))


def _run_declutter(args: argparse.Namespace) -> None:
    from symgrasp.benchmark.runner import check_out, markdown_table, run_benchmark

    threshold = _confidence_threshold(args)
    options = () if threshold is None else (("confidence_threshold", threshold),)
    if args.validity is not None:
        options += (("validity_threshold", args.validity),)
    config = dataclasses.replace(config_from_args(BenchmarkConfig, args), options=options)
    parallel = parallel_from_args(args)
    check_out(config, args.out, args.resume)  # before the model loads
    if args.representation is not None or args.gripper is not None:
        from symgrasp.detect.pretrained import trained_for
        from symgrasp.sim.grippers import get_gripper, same_name_note

        rep, hand = trained_for(args.model)  # read from the checkpoint: no network is built
        if args.representation not in (None, rep):
            raise SystemExit(
                f"error: --rep {args.representation}, but --model {args.model} is {rep}"
            )
        asked = None if args.gripper is None else get_gripper(args.gripper)  # resolved once
        if asked not in (None, hand):
            note = same_name_note(hand, asked)
            raise SystemExit(
                f"error: --gripper {args.gripper}, but --model {args.model} is {hand.name}{note}"
            )
    summary = run_benchmark(config, args.out, args.resume, parallel)
    print(markdown_table(summary, config), end="")
    print(f"outcomes {summary['outcomes']}")
    print(f"failure modes {summary['modes']}; results in {args.out}")


# -- the command --------------------------------------------------------------------------


class _Parser(argparse.ArgumentParser):
    """Argument errors in one line: the command, the option, what was expected."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="symgrasp",
        description="Learning 6-DoF grasp detection for parallel grippers with a "
        "planar-symmetric 2D-Bingham SO(3) representation.",
    )
    subparsers = parser.add_subparsers(
        dest="command", required=True, metavar="COMMAND", help="the job to run"
    )
    _add_demo(subparsers)
    _add_objects(subparsers)
    _add_sim(subparsers)
    _add_gripper(subparsers)
    _add_data(subparsers)
    _add_figures(subparsers)
    _add_train(subparsers)
    _add_select(subparsers)
    _add_detect(subparsers)
    _add_export(subparsers)
    _add_bench(subparsers)
    return parser


def main(argv: Sequence[str] | None = None) -> None:
    args = build_parser().parse_args(argv)
    try:
        args.run(args)
    except ValueError as error:  # bad input: the message names the argument, no traceback needed
        raise SystemExit(f"error: {error}") from error
    except TasksFailed as error:  # the message says which tasks failed and where the tracebacks are
        raise SystemExit(f"error: {error}") from error
    except ModuleNotFoundError as error:  # an optional extra not installed: its message says which
        raise SystemExit(f"error: {error}") from error
    except OSError as error:  # a path that cannot be read or written: name it
        where = f"{error.filename}: " if error.filename else ""
        raise SystemExit(f"error: {where}{error.strerror or error}") from error
