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


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="symgrasp",
        description="Learning 6-DoF grasp detection for parallel grippers with a "
        "planar-symmetric 2D-Bingham SO(3) representation.",
    )
    subparsers = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    _add_demo(subparsers)
    return parser


def main(argv: Sequence[str] | None = None) -> None:
    args = build_parser().parse_args(argv)
    args.run(args)
