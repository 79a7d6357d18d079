"""The options several ``symgrasp`` commands share, defined once: ``--objects``, ``--gripper``,
``--model``, ``--rep`` and the other names of `SHARED` (their choices from `symgrasp.names`),
``--mesh-unit``, the confidence pair, and the seed, probability and output path types."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from symgrasp.arguments import integer, number, sentence
from symgrasp.config import SEED_MAX, SceneConfig
from symgrasp.fields import field_docs
from symgrasp.folders import check_path
from symgrasp.names import (
    GRIPPER_SPEC_SUFFIX,
    GRIPPERS,
    MESH_OBJECT_SETS,
    MESH_UNITS,
    OBJECT_SETS,
    PEERS,
    PRETRAINED,
    REPRESENTATIONS,
    SCENES,
    SCHEDULES,
    VALIDITY_LOSSES,
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


def output_path(value: str) -> str:
    """An argparse type: the path of a folder or file a command writes, not empty or blank
    (`symgrasp.folders.check_path`: ``''`` would write into the current folder)."""
    try:
        check_path(value, None)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None
    return value


def parse_gripper(value: str) -> str:
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

PLANNER_METAVAR = "{" + ",".join((*PRETRAINED, *PEERS)) + "}|CHECKPOINT|MODULE:NAME"
"""How a planner is shown where any may play (``detect``, ``bench declutter``): a shipped
model, a peer detector (VGN's network), a checkpoint file or a user's planner
(`symgrasp.peers.planners`)."""

SHARED = {
    "objects": ("--objects", {"type": parse_object_set, "metavar": "SET|FOLDER"}),
    "object_set": ("--objects", {"type": parse_object_set, "metavar": "SET|FOLDER"}),
    "scene": ("--scene", {"choices": SCENES}),
    "gripper": ("--gripper", {"type": parse_gripper, "metavar": GRIPPER_METAVAR}),
    "model": ("--model", {"metavar": PLANNER_METAVAR}),
    "representation": ("--rep", {"choices": REPRESENTATIONS}),
    "kinds": ("--kinds", {"choices": SCENES}),
    "mesh_unit": ("--mesh-unit", {"choices": MESH_UNITS}),
    "schedule": ("--schedule", {"choices": SCHEDULES}),
    "validity.kind": ("--validity-loss", {"choices": VALIDITY_LOSSES}),
    "out": ("--out", {"type": output_path}),
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


def add_mesh_unit(parser: argparse.ArgumentParser) -> None:
    """``--mesh-unit``, as `SceneConfig.mesh_unit` documents it, on a command without a
    configuration."""
    help = sentence(field_docs(SceneConfig)["mesh_unit"])
    add_shared(parser, "mesh_unit", f"{help} (default: auto)", "auto")


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
