"""Training-seed variation of the Robotiq comparison → benchmarks/results/seed_check.json.

    PYTHONPATH=src python benchmarks/seed_check.py [--workers 2] [--backend ray [--ray-address HOST:PORT]] [--quick [DIR]]

The one-seed comparison on household objects (``declutter_table.py`` as it was at 7403154;
``seed_spread.py`` and today's ``declutter_table.py`` do this over three seeds on VGN's
objects) trained every detector once (``--seed 0``). This script
benchmarks the second runs of the Robotiq ``bingham2d`` and ``rotmat6d``, trained with

    symgrasp train --data data/robotiq-train --rep REP --gripper robotiq-2f85 \\
        --out runs/REP-robotiq-seed1 --epochs 30 --batch-size 4 --seed 1

on the same 100 rounds as the table (cells in ``out/bench/seed1/robotiq/REP/OBJECTS``, read
back when present), and compares ``bingham2d`` with ``rotmat6d`` within each training seed on
the same rounds (`symgrasp.benchmark.compare.paired_change`). The seed-0 cells are the table's
(``out/bench/robotiq/REP/OBJECTS``; run that ``declutter_table.py`` first). ``--quick`` needs no
training run: the shipped Robotiq model stands in for every run, and it plays the seed-0 cells
too, one round of one object per cell.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from common import add_result_option, parse_args, percent_change, write_result

from symgrasp.benchmark.compare import paired_change
from symgrasp.benchmark.runner import BenchmarkConfig, run_or_reuse, summarise
from symgrasp.parallel.options import add_parallel_options, parallel_from_args

REPS = ("bingham2d", "rotmat6d")
SHIPPED = "bingham2d-robotiq-2f85"
OBJECTS = ("household-test", "large-box")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", default="runs", help="folder of the training runs")
    parser.add_argument("--out", default="out/bench", help="folder of the benchmark cells")
    parser.add_argument("--rounds", type=int, default=100, help="rounds per cell (default: 100)")
    parser.add_argument("--num-objects", type=int, default=5, help="objects per round (default: 5)")
    add_parallel_options(parser, "rounds")
    parser.set_defaults(workers=2)
    add_result_option(parser, "seed_check")
    args = parse_args(
        parser,
        outputs=("out", "result"),
        quick={"rounds": 1, "num_objects": 1, "workers": 1},
        also=f"{SHIPPED} for every training run",
    )

    rounds = {}
    for rep in REPS:
        for objects in OBJECTS:
            run = str(Path(args.runs) / f"{rep}-robotiq-seed1" / "best.pt")
            config = BenchmarkConfig(
                model=SHIPPED if args.quick else run,
                objects=objects,
                num_objects=args.num_objects,
                rounds=args.rounds,
                seed=0,
            )
            seed0 = Path(args.out) / "robotiq" / rep / objects / "rounds.jsonl"
            if args.quick:  # the seed-0 cell that the one-seed table would have played
                run_or_reuse(config, seed0.parent, parallel_from_args(args))
            if not seed0.exists():
                raise SystemExit(
                    f"error: {seed0} is missing; run declutter_table.py of 7403154 first"
                )
            rounds[rep, 0, objects] = [json.loads(x) for x in seed0.read_text().splitlines()]
            folder = Path(args.out) / "seed1" / "robotiq" / rep / objects
            rounds[rep, 1, objects] = run_or_reuse(config, folder, parallel_from_args(args))

    cells = [{"rep": rep, "training_seed": seed, "objects": objects,
              "summary": summarise(rounds[rep, seed, objects], 0)}
             for rep, seed, objects in rounds]  # fmt: skip
    lead = [{"training_seed": seed, "objects": objects,
             "bingham2d_minus_rotmat6d": paired_change(rounds["bingham2d", seed, objects],
                                                       rounds["rotmat6d", seed, objects])}
            for seed in (0, 1) for objects in OBJECTS]  # fmt: skip
    for row in cells:
        s = row["summary"]
        print(f"{row['rep']:10s} seed {row['training_seed']} {row['objects']:15s} "
              f"SR {100 * s['success_ratio']:.1f} CR {100 * s['clear_ratio']:.1f}")  # fmt: skip
    for row in lead:
        change = row["bingham2d_minus_rotmat6d"]
        print(f"bingham2d − rotmat6d, seed {row['training_seed']}, {row['objects']}: "
              + ", ".join(f"{k} {percent_change(v)}" for k, v in change.items()))  # fmt: skip
    write_result(
        args.result,
        "training-seed variation of the Robotiq bingham2d and rotmat6d",
        "PYTHONPATH=src python benchmarks/seed_check.py",
        cells,
        paired_lead=lead,
    )


if __name__ == "__main__":
    main()
