"""Declutter results per validity threshold → experiments/results/validity_sweep.{json,md}.

    PYTHONPATH=src python experiments/validity_sweep.py [--rounds 100] [--choosing-rounds 200]
        [--num-objects 5] [--workers 2] [--backend ray [--ray-address HOST:PORT]] [--quick [DIR]]

The detector keeps voxels whose validity is at least a threshold (`DEFAULT_VALIDITY`, one
value for every model), so SR and CR are one operating point of a trade-off: a stricter
threshold executes fewer, surer grasps (SR up) and ends more rounds with nothing found (CR
down). This script plays the shipped `bingham2d` and `rotmat6d` model of each hand (Table 1's
question: does the ordering depend on the operating point?) at several thresholds:

- on *training* objects (``vgn-pile-train``, the judging rounds from `JUDGE_SEED`, off
  the test seeds and the checkpoint selection's), where each model's own threshold is chosen by
  SR + CR, the measure the checkpoints were selected by;
- on the test piles (``vgn-pile-test``, seeds 0–99, Table 1's rounds), as a sensitivity
  analysis, never to choose by.

Every threshold is compared with the default on the same rounds (paired bootstrap over
rounds), and per hand `bingham2d` − `rotmat6d` on the test rounds at the default and at each
model's own threshold. One training seed per model (the shipped one), so the rows show how much
the operating point moves a comparison, not which representation is better. Failure modes are
not diagnosed (`--no-diagnose`); a cell whose folder already holds the same configuration's
rounds is read, not rerun (`runner.run_or_reuse`). ``--quick`` plays one round of one object
per cell with one hand's models at two thresholds.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from common import add_approach_check, add_result_option
from scripts import command_line, parse_args, run_main, write_result

from symgrasp.benchmark.compare import paired_change, percent_change
from symgrasp.benchmark.runner import (
    BenchmarkConfig,
    percent_with_interval,
    run_or_reuse,
    summarise,
)
from symgrasp.benchmark.seeds import common_rounds
from symgrasp.cli.options import approach_check
from symgrasp.config import DEFAULT_VALIDITY, JUDGE_SEED, PlannerOptions
from symgrasp.parallel.options import add_parallel_options, parallel_from_args

MODELS = {  # hand: (the paper's detector, the baseline it is compared with)
    "robotiq-2f85": ("bingham2d-robotiq-2f85", "rotmat6d-robotiq-2f85"),
    "franka": ("bingham2d-franka", "rotmat6d-franka"),
}
THRESHOLDS = tuple(sorted({0.04, 0.06, DEFAULT_VALIDITY, 0.11}))
CHOOSING = ("vgn-pile-train", JUDGE_SEED)
TESTING = ("vgn-pile-test", 0)


def _pooled(rounds: list[dict], seed: int) -> dict:
    """`summarise` without the per-object breakdown (each cell's folder keeps it)."""
    return {k: v for k, v in summarise(rounds, seed).items() if k != "families"}


def own_threshold(rows: list[dict]) -> float:
    """The threshold of ``rows`` (one model's, on the choosing set) with the largest SR + CR;
    the lower threshold on a tie. A cell that executed no grasp (SR undefined) ranks last."""

    def score(row: dict) -> tuple[float, float]:
        total = row["summary"]["success_ratio"] + row["summary"]["clear_ratio"]
        return (total if math.isfinite(total) else -math.inf, -row["validity"])

    return max(rows, key=score)["validity"]


def markdown(rows: list[dict], points: list[dict]) -> str:
    """The sweep (SR, CR with intervals, CR change from the default, grasps executed, rounds
    ended with nothing found) and, per hand, the comparison at one and at each own threshold."""
    text = ["| model | objects (seeds) | validity ≥ | SR % [95 % CI] | CR % [95 % CI] | "
            "CR − default's [paired 95 % CI] | executed | no grasp found |",
            "|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for row in rows:
        s = row["summary"]
        default = " (default)" if row["validity"] == DEFAULT_VALIDITY else ""
        own = " (own)" if row["validity"] == row["own"] else ""
        change = "–" if default else percent_change(row["change"]["clear_ratio"])
        text.append(
            f"| {row['model']} | {row['objects']} ({row['seed']}–{row['seed'] + s['rounds'] - 1})"
            f" | {row['validity']}{default}{own} | {percent_with_interval(s, 'success_ratio')} "
            f"| {percent_with_interval(s, 'clear_ratio')} | {change} | {s['executed']} "
            f"| {s['outcomes'].get('none_found', 0)} |"
        )
    text += ["", f"`bingham2d` − `rotmat6d` on the same {TESTING[0]} rounds, each at the default "
             f"threshold and each at its own (chosen on {CHOOSING[0]}):", "",
             "| hand | thresholds | SR change [paired 95 % CI] | CR change [paired 95 % CI] |",
             "|---|---|---|---|"]  # fmt: skip
    for p in points:
        text.append(f"| {p['gripper']} | {p['thresholds'][0]} / {p['thresholds'][1]} | "
                    f"{percent_change(p['change']['success_ratio'])} | "
                    f"{percent_change(p['change']['clear_ratio'])} |")  # fmt: skip
    return "\n".join(text) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--rounds", type=int, default=100, help=f"rounds per {TESTING[0]} cell (default: 100)"
    )
    parser.add_argument(
        "--choosing-rounds",
        type=int,
        default=200,
        help=f"rounds per {CHOOSING[0]} cell, where each model's threshold is chosen "
        "(default: 200)",
    )
    parser.add_argument("--num-objects", type=int, default=5, help="objects per round (default: 5)")
    add_parallel_options(parser, "rounds")
    parser.set_defaults(workers=2)
    parser.add_argument("--out", default="out/validity_sweep", help="per-cell benchmark folders")
    add_result_option(parser, "validity_sweep")
    add_approach_check(parser)
    args = parse_args(
        parser,
        outputs=("out", "result"),
        quick={"rounds": 1, "choosing_rounds": 1, "num_objects": 1, "workers": 1},
        also=f"the {next(iter(MODELS))} models at validity 0.04 and {DEFAULT_VALIDITY} only",
    )
    hands = dict(list(MODELS.items())[:1]) if args.quick else MODELS
    thresholds = (0.04, DEFAULT_VALIDITY) if args.quick else THRESHOLDS

    rows, points = [], []
    for gripper, models in hands.items():
        test_rounds, own = {}, {}
        for model in models:
            for (objects, seed), rounds in ((CHOOSING, args.choosing_rounds),
                                            (TESTING, args.rounds)):  # fmt: skip
                played = {}
                for validity in thresholds:
                    print(f"{model} on {objects}, validity ≥ {validity}")
                    config = BenchmarkConfig(
                        model=model, objects=objects, num_objects=args.num_objects,
                        rounds=rounds, seed=seed, diagnose=False,
                        options=PlannerOptions(validity_threshold=validity),
                        **approach_check(args),
                    )  # fmt: skip
                    folder = Path(args.out) / model / objects / str(validity)
                    played[validity] = run_or_reuse(config, folder, parallel_from_args(args))
                cells = [{"gripper": gripper, "model": model, "objects": objects, "seed": seed,
                          "validity": validity, "summary": _pooled(played[validity], seed),
                          "change": paired_change(*common_rounds(played[validity],
                                                               played[DEFAULT_VALIDITY]))}
                         for validity in thresholds]  # fmt: skip
                if objects == CHOOSING[0]:
                    own[model] = own_threshold(cells)
                else:
                    test_rounds[model] = played
                rows += [{**cell, "own": own[model]} for cell in cells]
        paper, baseline = models
        for pair in ((DEFAULT_VALIDITY, DEFAULT_VALIDITY), (own[paper], own[baseline])):
            change = paired_change(
                *common_rounds(test_rounds[paper][pair[0]], test_rounds[baseline][pair[1]])
            )
            points.append({"gripper": gripper, "models": list(models), "thresholds": list(pair),
                           "objects": TESTING[0], "change": change})  # fmt: skip
    table = markdown(rows, points)
    print(table)
    write_result(
        args.result,
        "declutter SR / CR of the shipped bingham2d and rotmat6d models per validity threshold, "
        "each model's own threshold chosen on training objects, and bingham2d − rotmat6d at the "
        "default and at the own thresholds",
        command_line("PYTHONPATH=src"),
        rows,
        table,
        operating_points=points,
        rounds=args.rounds,
        choosing_rounds=args.choosing_rounds,
        num_objects=args.num_objects,
        default_validity=DEFAULT_VALIDITY,
    )


if __name__ == "__main__":
    run_main(main)
