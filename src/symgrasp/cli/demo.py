"""``symgrasp demo``: the shipped detector clears a simulated pile (`symgrasp.demo`)."""

from __future__ import annotations

import argparse

from symgrasp.arguments import integer
from symgrasp.cli.options import (
    MODEL_METAVAR,
    SEED,
    add_mesh_options,
    add_shared,
    output_folder_path,
    parse_model,
)
from symgrasp.config import MAX_OBJECTS
from symgrasp.names import demo_model


def add(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "demo",
        help="the main job of `make demo`: the shipped detector clears a simulated pile",
        description="Drop a random pile of objects in the MuJoCo world, then repeatedly render "
        "one depth image, detect grasps with a shipped model and execute the best "
        "collision-free one, until the table is clear or two grasps fail in a row. Prints "
        "every attempt and the round's success and clear ratios; writes a picture per attempt, "
        "demo.html and summary.json into --out.",
    )
    parser.add_argument(
        "--out",
        type=output_folder_path,
        default="out/demo",
        help="output folder (default: out/demo)",
    )
    parser.add_argument(
        "--seed", type=SEED, default=0, help="seed of the objects and the pile (default: 0)"
    )
    add_shared(
        parser,
        "gripper",
        "gripper: a built-in's name, whose shipped bingham2d model is used, or a spec file "
        "(then --model is needed) (default: robotiq-2f85)",
        "robotiq-2f85",
    )
    add_shared(parser, "objects", "object set (default: household-test)", "household-test")
    parser.add_argument(
        "--num-objects",
        type=integer(1, MAX_OBJECTS),
        default=5,
        help="objects dropped on the table (default: 5)",
    )
    parser.add_argument(
        "--model",
        type=parse_model,
        default=None,
        metavar=MODEL_METAVAR,
        help="another shipped model or a checkpoint path instead of the gripper's bingham2d model",
    )
    add_mesh_options(parser)
    parser.set_defaults(run=_run_demo)


def _run_demo(args: argparse.Namespace) -> None:
    if args.model is None:
        demo_model(args.gripper)  # a spec file needs --model: refused before the imports

    from symgrasp.demo import run_demo

    run_demo(
        args.out, args.seed, args.gripper, args.objects, args.num_objects, args.model,
        args.mesh_unit, args.decomposition,
    )  # fmt: skip
