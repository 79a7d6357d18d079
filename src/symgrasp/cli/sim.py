"""``symgrasp sim show`` and ``symgrasp gripper show``: pictures of the simulated world and of
a gripper (`symgrasp.sim`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from symgrasp.arguments import integer
from symgrasp.cli.options import (
    GRIPPER_METAVAR,
    SEED,
    add_mesh_options,
    add_shared,
    output_folder_path,
    output_path,
    parse_gripper,
)
from symgrasp.config import MAX_OBJECTS
from symgrasp.names import SCENES


def add(subparsers: argparse._SubParsersAction) -> None:
    _add_sim(subparsers)
    _add_gripper(subparsers)


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
    add_shared(
        show, "objects", "object set to draw from (default: household-train)",
        "household-train",
    )  # fmt: skip
    show.add_argument(
        "--n", type=integer(1, MAX_OBJECTS), default=5, help="number of objects (default: 5)"
    )
    show.add_argument("--seed", type=SEED, default=0, help="random seed (default: 0)")
    show.add_argument(
        "--out", type=output_folder_path, default="out/sim", help="output folder (default: out/sim)"
    )
    add_mesh_options(show)
    show.set_defaults(run=_run_sim_show)


def _run_sim_show(args: argparse.Namespace) -> None:
    from symgrasp.folders import PICTURES, output_folder
    from symgrasp.objects.sets import make_scene, resolve
    from symgrasp.sim.show import save_scene_pictures

    with output_folder(args.out, PICTURES, "--out"):  # checked before the objects load
        source = resolve(args.objects, args.mesh_unit, args.decomposition)
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
        "spec", type=parse_gripper, metavar=GRIPPER_METAVAR, help="a built-in's name or a spec file"
    )
    show.add_argument(
        "--out", type=output_path, help="picture path (default: out/gripper/<name>.png)"
    )
    show.set_defaults(run=_run_gripper_show)


def _run_gripper_show(args: argparse.Namespace) -> None:
    from symgrasp.sim.grippers import get_gripper

    spec = get_gripper(args.spec)

    from symgrasp.sim.show import save_gripper_png

    path = save_gripper_png(spec, args.out or f"out/gripper/{spec.name}.png")
    print(f"{spec.name} ({spec.kind}): opening {spec.max_width * 1000:g} mm, finger depth "
          f"{spec.finger_depth * 1000:.1f} mm, pads {spec.pad_width * 1000:g} mm wide, "
          f"{spec.grip_force:g} N; picture: {path}")  # fmt: skip
