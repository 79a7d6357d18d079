"""The ``symgrasp`` command: one sub-command per job, each a thin wrapper over the package."""

from __future__ import annotations

import argparse
from collections.abc import Sequence


def _add_demo(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "demo",
        help="the main job of `make demo`",
        description="Fit, sample and plot a 2D Bingham distribution (until the grasp pipeline "
        "exists), and print where the pictures went.",
    )
    parser.add_argument("--out", default="out/demo", help="output folder (default: out/demo)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default: 0)")

    def run(args: argparse.Namespace) -> None:
        from symgrasp.demo import run_demo

        run_demo(out=args.out, seed=args.seed)

    parser.set_defaults(run=run)


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
    show.add_argument(
        "--scene", choices=["pile", "packed"], default="pile", help="scene kind (default: pile)"
    )
    show.add_argument(
        "--objects",
        default="household-train",
        choices=["household-train", "household-test", "large-box", "blocks"],
        help="object set to draw from (default: household-train)",
    )
    show.add_argument("--n", type=int, default=5, help="number of objects (default: 5)")
    show.add_argument("--seed", type=int, default=0, help="random seed (default: 0)")
    show.add_argument("--out", default="out/sim", help="output folder (default: out/sim)")

    def run(args: argparse.Namespace) -> None:
        from symgrasp.perception.show import save_scene_pictures
        from symgrasp.sim import make_scene

        world = make_scene(args.scene, args.objects, n=args.n, seed=args.seed)
        stem = f"{args.scene}_{args.objects}_seed{args.seed}"
        paths, renderer = save_scene_pictures(world, args.out, stem)
        print(f"{len(world.objects)} objects settled: {', '.join(o.name for o in world.objects)}")
        print(f"depth renderer: {renderer}")
        for kind, path in paths.items():
            print(f"{kind}: {path}")

    show.set_defaults(run=run)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="symgrasp",
        description="Learning 6-DoF grasp detection for parallel grippers with a "
        "planar-symmetric 2D-Bingham SO(3) representation.",
    )
    subparsers = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    _add_demo(subparsers)
    _add_sim(subparsers)
    return parser


def main(argv: Sequence[str] | None = None) -> None:
    args = build_parser().parse_args(argv)
    args.run(args)
