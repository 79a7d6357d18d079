"""``symgrasp train`` (a training run) and ``symgrasp select`` (its best checkpoint by a
validation measure): the model's commands (`symgrasp.model`)."""

from __future__ import annotations

import argparse

from symgrasp.arguments import integer
from symgrasp.cli.fields import add_config_options, config_from_args
from symgrasp.cli.options import (
    SEED,
    add_approach_check,
    add_mesh_options,
    add_shared,
    approach_check,
    input_folder,
    parse_device,
    parse_measure,
)
from symgrasp.config import (
    MAX_OBJECTS,
    TEST_SEED_LIMIT,
    VALIDATION_OBJECTS,
    VALIDATION_ROUNDS,
    VALIDATION_SEED,
    TrainConfig,
    check_global_batch,
)
from symgrasp.names import SCENES
from symgrasp.parallel.options import add_parallel_options, parallel_from_args


def add(subparsers: argparse._SubParsersAction) -> None:
    _add_train(subparsers)
    _add_select(subparsers)


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
        "--nproc", type=integer(1, 1024), default=1,
        help="training processes on this machine, data-parallel (DistributedDataParallel: gloo "
        "on CPU, NCCL on GPU; as torchrun --nproc-per-node N -m symgrasp train does); "
        "--batch-size is the global batch, split evenly (default: 1)",
    )  # fmt: skip
    parser.set_defaults(run=_run_train)


def _run_train(args: argparse.Namespace) -> None:
    config = config_from_args(TrainConfig, args, prefixes=_TRAIN_PREFIXES)
    check_global_batch(config.batch_size, args.nproc)

    from symgrasp.model import distributed
    from symgrasp.model.train import train

    if args.nproc > 1:
        from symgrasp.device import resolve_device

        resolve_device(config.device)  # a device that is not there: refused once, not per rank
        distributed.launch(train, (config,), args.nproc)
        print(f"{config.epochs} epochs on {args.nproc} processes; checkpoints and metrics in "
              f"{config.out}")  # fmt: skip
        return
    history = train(config)
    if distributed.is_main_process():  # torchrun runs this command on every rank
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
        "run_dir",
        type=input_folder,
        metavar="RUN_DIR",
        help="run folder of symgrasp train (its --out)",
    )
    parser.add_argument(
        "--by", type=parse_measure, required=True, metavar="MEASURE",
        help="declutter (the declutter validation's success ratio plus clear ratio; "
        "declutter_sr the success ratio alone, declutter_cr the clear ratio), val_loss, or a "
        "column of RUN_DIR/metrics.csv: higher is better for validity_ap, the top-k shares "
        "(top1_valid, top5_correct, …) and the declutter measures, lower for losses (val_*), "
        "score_mae, angles (*_deg) and top_empty",
    )  # fmt: skip
    add_shared(
        parser, "objects",
        "object set of the declutter validation: training objects; a test set is refused "
        f"(default: {VALIDATION_OBJECTS})", VALIDATION_OBJECTS,
    )  # fmt: skip
    parser.add_argument(
        "--rounds", type=integer(1, 100_000), default=VALIDATION_ROUNDS,
        help=f"declutter validation rounds per checkpoint (default: {VALIDATION_ROUNDS})",
    )  # fmt: skip
    parser.add_argument(
        "--seed", type=SEED, default=VALIDATION_SEED,
        help="seed of the declutter validation's round 0; round r uses seed + r; seeds below "
        f"{TEST_SEED_LIMIT} are the test benchmarks' and refused (default: {VALIDATION_SEED})",
    )  # fmt: skip
    parser.add_argument(
        "--num-objects", type=integer(1, MAX_OBJECTS), default=5,
        help="objects per declutter validation round (default: 5)",
    )  # fmt: skip
    parser.add_argument(
        "--scene", choices=SCENES, default="pile",
        help="layout of the declutter validation's rounds (default: pile)",
    )  # fmt: skip
    add_mesh_options(parser, ("mesh_unit",))  # the validation plays the default parts
    add_approach_check(parser, "the declutter validation rounds")
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
        "--batch-size", type=integer(1, 4096), default=None,
        help="scenes per batch of --revalidate (default: the run's; on the dataset the run "
        "trained on, --revalidate also validates on its --val-scenes with its validity loss, "
        "so that metrics.csv's values come back)",
    )  # fmt: skip
    parser.add_argument(
        "--device",
        type=parse_device,
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
        scene=args.scene, mesh_unit=args.mesh_unit, **approach_check(args),
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
