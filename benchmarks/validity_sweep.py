"""Declutter results per validity threshold → benchmarks/results/validity_sweep.{json,md}.

    PYTHONPATH=src python benchmarks/validity_sweep.py [--rounds 100] [--num-objects 5]
        [--workers 2] [--backend ray [--ray-address HOST:PORT]] [--quick [DIR]]

The detector keeps voxels whose validity is at least a threshold (`DEFAULT_VALIDITY`). This
script plays 100 declutter rounds (`symgrasp bench declutter --validity V`) of each shipped
``bingham2d`` model at several thresholds: on *training* objects (``household-train``, seeds
1000–1099, no round shared with the test seeds 0–99), where a threshold may be chosen, and on
the test sets, as a sensitivity analysis of the published table (not to choose by). Each
threshold is compared with the default on the same rounds (same seeds, so the same piles at
the start): the change of CR and SR with a paired bootstrap 95 % interval over rounds. A cell
whose folder already holds the same configuration's results is read, not rerun
(`runner.run_or_reuse`). ``--quick`` plays one round of one object per cell, on the training
objects only.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from common import add_result_option, parse_args, write_result

from symgrasp.benchmark.compare import paired_change
from symgrasp.benchmark.runner import (
    BenchmarkConfig,
    percent_with_interval,
    run_or_reuse,
    summarise,
)
from symgrasp.cli import add_parallel_options, parallel_from_args
from symgrasp.config import DEFAULT_VALIDITY

MODELS = ("bingham2d-robotiq-2f85", "bingham2d-franka")
THRESHOLDS = tuple(sorted({0.02, 0.04, DEFAULT_VALIDITY, 0.15}))
SETS = (  # (objects, seed of round 0, what the rows are for)
    ("household-train", 1000, "choosing"),
    ("household-test", 0, "sensitivity"),
    ("large-box", 0, "sensitivity"),
)


def markdown(rows: list[dict]) -> str:
    """One table: SR, CR with intervals and rounds ended with no grasp, per model, object set
    and threshold."""
    text = [
        "| model | objects (seeds) | validity ≥ | SR % [95 % CI] | CR % [95 % CI] | "
        "CR − default's [paired 95 % CI] | no grasp found | collision |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for row in rows:
        s = row["summary"]
        default = " (default)" if row["validity"] == DEFAULT_VALIDITY else ""
        d, lo, hi = (100 * v for v in row["change"]["clear_ratio"])
        change = "–" if default else f"{d:+.1f} [{lo:+.1f}, {hi:+.1f}]"
        text.append(
            f"| {row['model']} | {row['objects']} ({row['seed']}–{row['seed'] + s['rounds'] - 1}) "
            f"| {row['validity']}{default} | {percent_with_interval(s, 'success_ratio')} "
            f"| {percent_with_interval(s, 'clear_ratio')} | {change} "
            f"| {s['outcomes'].get('none_found', 0)} "
            f"| {s['modes'].get('collision', 0)} |"
        )
    return "\n".join(text) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=100, help="rounds per cell (default: 100)")
    parser.add_argument("--num-objects", type=int, default=5, help="objects per round (default: 5)")
    add_parallel_options(parser, "rounds")
    parser.set_defaults(workers=2)
    parser.add_argument("--out", default="out/validity_sweep", help="per-cell benchmark folders")
    add_result_option(parser, "validity_sweep")
    args = parse_args(
        parser,
        outputs=("out", "result"),
        quick={"rounds": 1, "num_objects": 1, "workers": 1},
        also=f"on {SETS[0][0]} only",
    )

    rows = []
    for model in MODELS:
        for objects, seed, purpose in SETS[:1] if args.quick else SETS:
            played = {}
            for validity in THRESHOLDS:
                print(f"{model} on {objects}, validity ≥ {validity}")
                options = (("validity_threshold", validity),)
                config = BenchmarkConfig(
                    model=model,
                    objects=objects,
                    num_objects=args.num_objects,
                    rounds=args.rounds,
                    seed=seed,
                    options=options,
                )
                folder = Path(args.out) / model / objects / str(validity)
                played[validity] = run_or_reuse(config, folder, parallel_from_args(args))
            for validity, rounds in played.items():
                rows.append({"model": model, "objects": objects, "seed": seed,
                             "purpose": purpose, "validity": validity,
                             "summary": summarise(rounds, seed),
                             "change": paired_change(rounds, played[DEFAULT_VALIDITY])})  # fmt: skip
    table = markdown(rows)
    print(table)
    write_result(
        args.result,
        "declutter SR / CR of the shipped bingham2d models per validity threshold",
        "PYTHONPATH=src python benchmarks/validity_sweep.py",
        rows,
        table,
        rounds=args.rounds,
        num_objects=args.num_objects,
        default_validity=DEFAULT_VALIDITY,
    )


if __name__ == "__main__":
    main()
