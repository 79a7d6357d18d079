"""The options several ``symgrasp`` commands share, defined once: ``--objects``, ``--gripper``,
``--model``, ``--rep`` and the other names of `SHARED` (their choices from `symgrasp.names`),
``--mesh-unit`` and ``--decomposition``, the confidence pair, and the seed, probability and
output path types."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from symgrasp.arguments import integer, number, sentence
from symgrasp.config import (
    DEFAULT_VALIDITY,
    MAX_VIEWS,
    SEED_MAX,
    BenchmarkConfig,
    SceneConfig,
    check_device,
)
from symgrasp.fields import field_docs
from symgrasp.folders import check_folder, check_path
from symgrasp.names import (
    DECOMPOSITIONS,
    GRIPPER_SPEC_SUFFIX,
    GRIPPERS,
    MESH_OBJECT_SETS,
    MESH_UNITS,
    NOISES,
    OBJECT_SETS,
    ORACLE,
    PEERS,
    PRETRAINED,
    REPRESENTATIONS,
    SCENES,
    SCHEDULES,
    VALIDITY_LOSSES,
    VIEWS,
    measure_direction,
    planner_kind,
)
from symgrasp.objects.folder import data_folder


def parse_object_set(value: str) -> str:
    """An object set's name, an existing folder, or mesh sets and folders joined by commas
    (read and checked when the command runs)."""
    parts = value.split(",")
    if not all(p.strip() for p in parts):
        raise argparse.ArgumentTypeError(
            f"expected a set's name, a folder, or names joined by commas, got {value!r}: an "
            "empty name would read the current folder"
        )
    if value in OBJECT_SETS or all(
        p in MESH_OBJECT_SETS or Path(p).expanduser().is_dir() for p in parts
    ):
        return value
    raise argparse.ArgumentTypeError(
        f"expected one of {', '.join(OBJECT_SETS)} (mesh sets are read from the data folder "
        f"{data_folder()}), a folder of URDF files or meshes, or mesh sets and folders joined "
        f"by commas, got {value!r}"
    )


def _named(value: str) -> Path:
    """``value`` as a Path; an argparse error when it is empty or blank
    (`symgrasp.folders.check_path`)."""
    try:
        return check_path(value, None)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def output_path(value: str) -> str:
    """An argparse type: the path of a file a command writes, not empty or blank
    (`symgrasp.folders.check_path`: ``''`` would write into the current folder) and not a
    folder."""
    if _named(value).is_dir():
        raise argparse.ArgumentTypeError(f"expected a file to write, got the folder {value!r}")
    return value


def output_folder_path(value: str) -> str:
    """An argparse type: the path of a folder a command writes into, not empty or blank and
    neither a file nor under one (`symgrasp.folders.check_folder`); what it may already hold is
    the command's to check."""
    try:
        check_folder(value, None)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None
    return value


def input_file(value: str) -> str:
    """An argparse type: an existing file the command reads, not a blank path (what it holds
    is checked when the command reads it)."""
    _named(value)
    if not Path(value).expanduser().is_file():
        what = "a folder" if Path(value).expanduser().is_dir() else "missing"
        raise argparse.ArgumentTypeError(f"expected an existing file, got {value!r} ({what})")
    return value


def parse_planner(value: str) -> str:
    """What may plan grasps where any planner plays (``detect``, ``bench declutter``): a model
    (`parse_model`), a peer's name (``vgn``: its weights are looked for when the command runs)
    or a user's ``package.module:NAME`` (imported when the command runs)."""
    return parse_model(value) if planner_kind(value) == "model" else value


def input_folder(value: str) -> str:
    """An argparse type: an existing folder the command reads (and may write its reports
    into), not a blank path (``''`` would be the current folder)."""
    _named(value)
    if not Path(value).expanduser().is_dir():
        what = "a file" if Path(value).expanduser().exists() else "missing"
        raise argparse.ArgumentTypeError(f"expected an existing folder, got {value!r} ({what})")
    return value


def parse_model(value: str) -> str:
    """A shipped model's name or an existing checkpoint file (read when the command runs)."""
    if value in PRETRAINED or Path(value).expanduser().is_file():
        return value
    raise argparse.ArgumentTypeError(
        f"expected a shipped model ({', '.join(PRETRAINED)}) or an existing checkpoint file, "
        f"got {value!r}"
    )


def parse_device(value: str) -> str:
    """An argparse type: a device name symgrasp runs on (`symgrasp.config.check_device`);
    whether this machine has CUDA is checked when the command runs, with torch."""
    try:
        check_device(value)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None
    return value


def parse_measure(value: str) -> str:
    """An argparse type: a measure ``symgrasp select --by`` may choose by
    (`symgrasp.names.measure_direction`); whether the run holds it is checked when it runs."""
    try:
        measure_direction(value)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error).removeprefix("--by: ")) from None
    return value


def parse_model_spec(value: str) -> str:
    """An argparse type: ``LABEL=MODEL``, a figure panel's title and a model (`parse_model`)."""
    label, separator, model = value.partition("=")
    if not separator or not label:
        raise argparse.ArgumentTypeError(
            f"expected LABEL=MODEL, e.g. bingham2d=best.pt, got {value!r}"
        )
    parse_model(model)
    return value


def parse_gripper(value: str) -> str:
    """A built-in gripper's name or an existing .toml spec file, read and checked whole now
    (`symgrasp.sim.grippers.load_gripper`: plain data, no simulator), so a bad spec stops the
    command before any work; the command resolves the name again where its work starts."""
    if value in GRIPPERS:
        return value
    if not (value.lower().endswith(GRIPPER_SPEC_SUFFIX) and Path(value).is_file()):
        raise argparse.ArgumentTypeError(
            f"expected one of {', '.join(GRIPPERS)} or an existing .toml gripper spec file "
            f"(docs/sim.md), got {value!r}"
        )
    from symgrasp.sim.grippers import load_gripper

    try:
        load_gripper(value)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None
    return value


GRIPPER_METAVAR = "{" + ",".join(GRIPPERS) + "}|SPEC" + GRIPPER_SPEC_SUFFIX
"""How ``--gripper``'s value is shown in every help."""

MODEL_METAVAR = "{" + ",".join(PRETRAINED) + "}|CHECKPOINT"
"""How ``--model``'s value is shown in every help: a shipped model's name or a file."""

PLANNER_METAVAR = "{" + ",".join((*PRETRAINED, *PEERS, ORACLE)) + "}|CHECKPOINT|MODULE:NAME"
"""How a planner is shown where any may play (``detect``, ``bench declutter``): a shipped
model, a peer detector (VGN's network), the oracle, a checkpoint file or a user's planner
(`symgrasp.peers.planners`)."""

SHARED = {
    "objects": ("--objects", {"type": parse_object_set, "metavar": "SET|FOLDER"}),
    "object_set": ("--objects", {"type": parse_object_set, "metavar": "SET|FOLDER"}),
    "scene": ("--scene", {"choices": SCENES}),
    "gripper": ("--gripper", {"type": parse_gripper, "metavar": GRIPPER_METAVAR}),
    "model": ("--model", {"type": parse_planner, "metavar": PLANNER_METAVAR}),
    "representation": ("--rep", {"choices": REPRESENTATIONS}),
    "kinds": ("--kinds", {"choices": SCENES}),
    "label_spread": ("--label-spread", {"metavar": ("BACK", "FORWARD", "E_Y", "E_Z")}),
    "mesh_unit": ("--mesh-unit", {"choices": MESH_UNITS}),
    "decomposition": ("--decomposition", {"choices": DECOMPOSITIONS}),
    "schedule": ("--schedule", {"choices": SCHEDULES}),
    "validity.kind": ("--validity-loss", {"choices": VALIDITY_LOSSES}),
    "out": ("--out", {"type": output_folder_path}),
    "noise": ("--noise", {"choices": NOISES}),
    "view": ("--view", {"choices": VIEWS}),
    "views": ("--views", {"type": integer(1, MAX_VIEWS), "metavar": "N"}),
}
"""How a field of these names (a nested one also by its path) appears on any command line: its
flag and its choices."""

SEED = integer(0, SEED_MAX)
"""An argparse type: a seed."""

PROBABILITY = number(0.0, 1.0)
"""An argparse type: a probability."""


def add_shared(parser: argparse.ArgumentParser, name: str, help: str, default: Any = None) -> None:
    """The shared option ``name`` (a key of `SHARED`) with its flag and choices."""
    flag, options = SHARED[name]
    parser.add_argument(flag, dest=name, default=default, help=help, **options)


MESH_OPTIONS = ("mesh_unit", "decomposition")
"""`SceneConfig`'s fields of how bare meshes are read: their units and their convex parts."""


def add_mesh_options(
    parser: argparse.ArgumentParser, names: tuple[str, ...] = MESH_OPTIONS
) -> None:
    """``--mesh-unit`` and ``--decomposition`` (``names``: those of `MESH_OPTIONS` wanted), as
    `SceneConfig` documents them, on a command without a configuration."""
    docs, defaults = field_docs(SceneConfig), SceneConfig()
    for name in names:
        default = getattr(defaults, name)
        add_shared(parser, name, f"{sentence(docs[name])} (default: {default})", default)


APPROACH_CHECK = ("table_clearance", "surface_clearance")
"""`BenchmarkConfig`'s fields of the approach check (`symgrasp.benchmark.declutter.first_free`):
the gaps the open hand keeps from the table and from the observed surface."""


def add_approach_check(parser: argparse.ArgumentParser, what: str) -> None:
    """``--table-clearance`` and ``--surface-clearance``, as `BenchmarkConfig` documents them,
    on a command that plays or reads declutter rounds without a benchmark configuration
    (``what``: the rounds, for the help); `approach_check` reads them."""
    docs, defaults = field_docs(BenchmarkConfig), BenchmarkConfig()
    for name in APPROACH_CHECK:
        default = getattr(defaults, name)
        parser.add_argument(
            "--" + name.replace("_", "-"), type=float, default=default, metavar="C",
            help=f"{sentence(docs[name])}, in {what} (default: {default})",
        )  # fmt: skip


def approach_check(args: argparse.Namespace) -> dict[str, float]:
    """The approach check's fields given on the command line (`add_approach_check`)."""
    return {name: getattr(args, name) for name in APPROACH_CHECK}


def add_decoding_options(parser: argparse.ArgumentParser) -> None:
    """A trained model's decoding options, the operating point of its model card where not
    given: ``--validity``, ``--confidence``/``--no-confidence``, ``--validity-floor``,
    ``--fallbacks`` and ``--no-operating-point`` (`decoding_options` reads them)."""
    parser.add_argument(
        "--validity",
        type=PROBABILITY,
        default=None,
        help=f"validity threshold (default: the model card's operating point, else "
        f"{DEFAULT_VALIDITY}; docs/models.md)",
    )
    add_confidence_options(parser)
    parser.add_argument(
        "--validity-floor",
        type=PROBABILITY,
        default=None,
        metavar="P",
        help="forced decoding: rank the voxels whose validity lies between P and the threshold "
        "after all those above it, so that a scene whose voxels all fall short still gets "
        "grasps (default: the model card's, else none; docs/detect.md)",
    )
    parser.add_argument(
        "--fallbacks",
        type=integer(0, 1000),
        default=None,
        metavar="N",
        help="after each voxel's grasp, N other rotations of the same voxel, tried when its "
        "approach is refused: draws of the Bingham output, most probable first (e_x kept), or "
        "for a point estimate its yaw turned about e_x in steps of 180/(N+1) degrees (default: "
        "the model card's, else 0; docs/detect.md)",
    )
    parser.add_argument(
        "--no-operating-point",
        action="store_true",
        help="ignore the model card's operating point: the library's defaults where an option "
        f"is not given (validity {DEFAULT_VALIDITY}, confidence 15 for bingham2d, no forced "
        "decoding, no fallbacks)",
    )


def decoding_options(args: argparse.Namespace) -> dict[str, Any]:
    """The `GraspDetector` options given by `add_decoding_options`' flags (those not given
    are left out: the model card's or the class's defaults apply)."""
    given = {
        "validity_threshold": args.validity,
        "confidence_threshold": confidence_threshold(args),
        "validity_floor": args.validity_floor,
        "fallbacks": args.fallbacks,
    }
    return {name: value for name, value in given.items() if value is not None}


def add_confidence_options(parser: argparse.ArgumentParser) -> None:
    """``--confidence`` and ``--no-confidence``, exclusive (`confidence_threshold` reads them)."""
    group = parser.add_mutually_exclusive_group()
    group.add_argument(
        "--confidence",
        type=number(0.0, 1e6),
        default=None,
        help="Bingham confidence threshold (default: 15 for bingham2d, none otherwise)",
    )
    group.add_argument(
        "--no-confidence",
        action="store_true",
        help="turn the confidence threshold off (the paper's 'without threshold' ablation)",
    )


def confidence_threshold(args: argparse.Namespace) -> float | None:
    """``GraspDetector``'s ``confidence_threshold`` from ``--confidence``/``--no-confidence``."""
    return 0.0 if args.no_confidence else args.confidence
