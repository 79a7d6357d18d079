"""``symgrasp bench declutter`` and ``bench compare``: benchmarks of trained detectors
(`symgrasp.benchmark`)."""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys

from symgrasp.arguments import sentence
from symgrasp.cli.fields import add_config_options, config_from_args
from symgrasp.cli.options import (
    PLANNER_METAVAR,
    add_decoding_options,
    add_shared,
    decoding_options,
    input_folder,
    output_folder_path,
    parse_planner,
)
from symgrasp.config import (
    TRAINING_DATABASE,
    BenchmarkConfig,
    DatabaseConfig,
    PlannerOptions,
)
from symgrasp.fields import field_docs
from symgrasp.names import ORACLE_GRIPPER, planner_kind
from symgrasp.parallel.options import add_parallel_options, parallel_from_args


def add(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "bench",
        help="benchmarks of grasp detectors",
        description="Benchmarks of grasp detectors: trained models, VGN's network, your own "
        "planner (symgrasp.benchmark).",
    )
    actions = parser.add_subparsers(
        dest="action", required=True, metavar="ACTION", help="what to run (declutter, compare)"
    )
    declutter = actions.add_parser(
        "declutter",
        help="simulated decluttering: success and clear ratios",
        description="VGN's and the paper's declutter protocol: each round drops --num-objects "
        "objects as a pile; before every attempt the cameras' depth images (--view, --views, "
        "--noise; by default one noiseless image from a fixed camera) are handed to the planner "
        "(--model: a trained model, vgn, the oracle or your own, docs/benchmark.md), and its best grasp "
        "whose approach misses the observed scene (those images fused) is executed; a round "
        "ends when "
        "the table is clear, no grasp is found or two attempts in a row fail. Round r uses seed "
        "--seed + r. Writes config.json, rounds.jsonl (each round as it finishes, so "
        "--resume can finish an interrupted run), then results.json (SR, CR with bootstrap "
        "95 % intervals over rounds, outcomes, failure modes, planning time) and results.md "
        "into --out. Each failed grasp is replayed from the state it started in, turned about "
        "its approach axis by 30..150 degrees: if a turn succeeds the failure was a wrong yaw, "
        "otherwise it is named by how it ended (collision, wrong approach = closed on nothing, "
        "slip).",
    )
    declutter.add_argument("--out", type=output_folder_path, required=True, help="output folder")
    declutter.add_argument(
        "--resume",
        action="store_true",
        help="finish the run in --out: play only the rounds missing from its rounds.jsonl "
        "(refused if --out holds a run of another configuration)",
    )
    add_parallel_options(declutter, "rounds")
    declutter.add_argument(
        "--model",
        "--planner",
        dest="model",
        type=parse_planner,
        default=BenchmarkConfig.model,
        metavar=PLANNER_METAVAR,
        help=sentence(field_docs(BenchmarkConfig)["model"])
        + f" (default: {BenchmarkConfig.model})",
    )
    add_config_options(declutter, BenchmarkConfig, skip=("model", "options"))
    add_decoding_options(declutter)
    declutter.add_argument(
        "--approach-check",
        action="store_true",
        help="a trained model checks its own grasps' approach against what it sees "
        "(GraspDetector(approach_check=True): a robot's check, trying each voxel's --fallbacks "
        "before the next voxel); what --protocol paper then executes is the first grasp that "
        "passes it (default: off; docs/detect.md)",
    )
    add_shared(
        declutter,
        "representation",
        "refuse to run unless --model uses this rotation representation (a guard for scripts: "
        "the checkpoint, not this option, decides the representation)",
    )
    for name, field in (("grasps", "grasps"), ("directions", "directions")):
        declutter.add_argument(
            f"--oracle-{name}",
            type=int,
            default=None,
            metavar="N",
            help=f"--model oracle only: {sentence(field_docs(DatabaseConfig)[field]).rstrip('.')} "
            f"in the oracle's databases (default: {getattr(TRAINING_DATABASE, field)}, the "
            "shipped models' training data; fewer: cheaper databases, docs/benchmark.md)",
        )
    declutter.add_argument(
        "--oracle-offset",
        type=float,
        nargs=2,
        default=None,
        metavar=("LO", "HI"),
        help=f"--model oracle only: {sentence(field_docs(DatabaseConfig)['offset']).rstrip('.')} "
        f"in the oracle's databases (default: {' '.join(map(str, TRAINING_DATABASE.offset))})",
    )
    add_shared(
        declutter,
        "gripper",
        "the hand, a built-in's name or a spec file: for vgn (default: franka), the oracle "
        f"(default: {ORACLE_GRIPPER}) and your own planner function, the hand simulated; for a model, a guard: refuse to run unless "
        "--model was trained for it (its gripper, stored in it, is the one simulated)",
    )
    declutter.set_defaults(run=_run_declutter)
    compare = actions.add_parser(
        "compare",
        help="the paired change of SR and CR between two benchmarks of the same rounds",
        description="Compare two `bench declutter` folders on the rounds both finished (the same "
        "seeds drop the same objects the same way): SR and CR of each and A − B with a 95 % "
        "interval from one bootstrap over rounds resampled in pairs. The folders must play the "
        "same world (objects, mesh units, scene, objects per round); the models, thresholds and "
        "hands may differ.",
    )
    compare.add_argument("a", type=input_folder, help="benchmark folder A")
    compare.add_argument("b", type=input_folder, help="benchmark folder B (the baseline)")
    compare.set_defaults(run=_run_compare)


def _run_compare(args: argparse.Namespace) -> None:
    from symgrasp.benchmark.compare import compare_table

    print(compare_table(args.a, args.b))


def _run_declutter(args: argparse.Namespace) -> None:
    kind = planner_kind(args.model)
    given = decoding_options(args)
    oracle = {"grasps": args.oracle_grasps, "directions": args.oracle_directions,
              "offset": None if args.oracle_offset is None else tuple(args.oracle_offset)}  # fmt: skip
    oracle = {k: v for k, v in oracle.items() if v is not None}
    if oracle and kind != "oracle":
        raise SystemExit(f"error: --oracle-* options are the oracle's, not --model {args.model}'s")
    if kind != "model":
        if given or args.no_operating_point or args.approach_check or args.representation:
            raise SystemExit(
                "error: --validity, --confidence, --no-confidence, --validity-floor, "
                "--fallbacks, --no-operating-point, --approach-check and --rep are a trained "
                f"model's; --model {args.model} takes none of them"
            )
        options = PlannerOptions(gripper=args.gripper, **oracle)
    if kind == "plugin" and os.getcwd() not in sys.path:
        sys.path.insert(0, os.getcwd())  # the planner's module, found as `python -m` finds it
    config = config_from_args(BenchmarkConfig, args)
    parallel = parallel_from_args(args)
    if kind == "model":
        from symgrasp.detect.pretrained import shipped_operating_point

        # the card's operating point, resolved here so that config.json records it whole
        card = {} if args.no_operating_point else shipped_operating_point(args.model)
        options = PlannerOptions(**{**card, **given}, approach_check=args.approach_check)
    config = dataclasses.replace(config, options=options)

    from symgrasp.benchmark.runner import check_out, markdown_table, run_benchmark

    check_out(config, args.out, args.resume)  # before the model loads
    if kind == "model":  # a network its weights do not fit: refused before a file is written
        from symgrasp.detect.pretrained import resolve_model
        from symgrasp.model.checkpoint import load_model, trained_gripper

        _, state = load_model(resolve_model(args.model))
    if kind == "model" and (args.representation is not None or args.gripper is not None):
        from symgrasp.sim.grippers import get_gripper, same_name_note

        rep, hand = state["representation"], trained_gripper(state)
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
    from symgrasp.objects.sets import resolve

    objects = resolve(config.objects, config.mesh_unit, config.decomposition)
    objects.check()  # every object, before the first round
    summary = run_benchmark(config, args.out, args.resume, parallel)
    print(markdown_table(summary, config), end="")
    print(f"outcomes {summary['outcomes']}")
    if summary["struck"]:
        print(f"collisions hit (attempts; table includes walls) {summary['struck']}")
    left = [f"{f} {c['left']}/{c['presented']}" for f, c in summary["left_on_table"].items()
            if c["left"]]  # fmt: skip
    if left:
        print(f"left on the table (of presented), most often first: {', '.join(left[:10])}")
    print(f"failure modes {summary['modes']}; results in {args.out}")
