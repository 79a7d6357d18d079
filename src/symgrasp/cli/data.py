"""``symgrasp data generate``, ``data relabel``, ``data inspect`` and ``data show``: labelled
grasp datasets (`symgrasp.data`)."""

from __future__ import annotations

import argparse

from symgrasp.arguments import integer, number, sentence
from symgrasp.cli.fields import add_config_options, config_from_args
from symgrasp.cli.options import SEED, input_folder, output_folder_path, output_path
from symgrasp.config import SceneConfig
from symgrasp.fields import field_docs
from symgrasp.parallel.options import add_parallel_options, parallel_from_args


def add(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "data",
        help="generate and inspect grasp datasets",
        description="Per-object grasp databases, labelled cluttered scenes, dataset cards "
        "(docs/data.md).",
    )
    actions = parser.add_subparsers(
        dest="action",
        required=True,
        metavar="ACTION",
        help="what to do (generate, relabel, inspect, show)",
    )
    gen = actions.add_parser(
        "generate",
        help="write a labelled dataset",
        description="Build (or reuse) the grasp database of every pool object, then write "
        "labelled scenes as one compressed file each, atomically; --resume continues an "
        "interrupted run. Every field of the dataset's configuration (symgrasp.config."
        "SceneConfig, and its DatabaseConfig) is an option.",
    )
    gen.add_argument("--out", type=output_folder_path, required=True, help="dataset folder")
    gen.add_argument(
        "--scenes", type=integer(1, 10**7), default=2000, help="number of scenes (default: 2000)"
    )
    gen.add_argument("--seed", type=SEED, default=0, help="dataset seed (default: 0)")
    add_parallel_options(gen, "databases and scenes")
    gen.add_argument(
        "--resume", action="store_true", help="continue a run in --out, skipping written scenes"
    )
    add_config_options(gen, SceneConfig)
    gen.set_defaults(run=_run_data_generate)

    relabel = actions.add_parser(
        "relabel",
        help="a dataset's scenes with the labels of another --label-spread",
        description="Write the scenes of a finished dataset with the labels generation gives "
        "with another --label-spread (by default none: each surviving grasp at its TCP's voxel "
        "alone): the same objects, grasps, camera, depth image and TSDF, without simulating the "
        "scenes again, for an ablation of the labels on the same scenes (docs/data.md, "
        '"Relabelled datasets").',
    )
    relabel.add_argument("src", type=input_folder, help="finished dataset")
    relabel.add_argument("--out", type=output_folder_path, required=True, help="dataset folder")
    relabel.add_argument(
        "--label-spread",
        type=number(0.0, 0.05),
        nargs=4,
        default=(0.0, 0.0, 0.0, 0.0),
        metavar=("BACK", "FORWARD", "E_Y", "E_Z"),
        help=sentence(field_docs(SceneConfig)["label_spread"]) + " (default: 0 0 0 0)",
    )
    relabel.add_argument(
        "--resume", action="store_true", help="continue a run in --out, skipping written scenes"
    )
    relabel.set_defaults(run=_run_data_relabel)

    inspect = actions.add_parser(
        "inspect",
        help="print counts and write the dataset card",
        description="Print counts, class balance and score histograms of a dataset and write "
        "card.json and card.png into it.",
    )
    inspect.add_argument("root", type=input_folder, help="dataset folder")
    inspect.add_argument(
        "--validate",
        type=integer(0, 100_000),
        default=50,
        help="physics trials for the card: the grasps of labelled voxels drawn uniformly as "
        "stored (TCP at the voxel's centre, one of its rotation targets; those a --label-spread "
        "added also apart) against random grasps in the same scenes; 0 skips them (default: 50)",
    )
    inspect.add_argument("--seed", type=SEED, default=0, help="seed of the trials (default: 0)")
    inspect.set_defaults(run=_run_data_inspect)

    show = actions.add_parser(
        "show",
        help="draw one scene",
        description="Draw a scene's TSDF surface, its labelled grasps and its depth image.",
    )
    show.add_argument("root", type=input_folder, help="dataset folder")
    show.add_argument("--scene", type=integer(0, 10**7), default=0, help="scene id (default: 0)")
    show.add_argument("--out", type=output_path, help="picture path (default: ROOT/scene_<id>.png)")
    show.set_defaults(run=_run_data_show)


def _run_data_generate(args: argparse.Namespace) -> None:
    config = config_from_args(SceneConfig, args)
    parallel = parallel_from_args(args)

    from symgrasp.data.generate import generate

    manifest = generate(args.out, config, args.scenes, args.seed, args.resume, parallel)
    print(f"{manifest['num_scenes']} scenes in {args.out} (hash {manifest['dataset_hash']})")


def _run_data_relabel(args: argparse.Namespace) -> None:
    from symgrasp.data.relabel import relabel

    manifest = relabel(args.src, args.out, args.resume, tuple(args.label_spread))
    print(f"{manifest['num_scenes']} scenes in {args.out} (hash {manifest['dataset_hash']})")


def _run_data_inspect(args: argparse.Namespace) -> None:
    import json

    from symgrasp.data.card import dataset_card

    print(json.dumps(dataset_card(args.root, args.validate, args.seed), indent=1))


def _run_data_show(args: argparse.Namespace) -> None:
    from symgrasp.data.card import show_scene

    print(show_scene(args.root, args.scene, args.out))
