"""Declutter results per validity threshold → benchmarks/results/validity_sweep.{json,md}.

    PYTHONPATH=src python benchmarks/validity_sweep.py [--rounds 100] [--workers 2]

The detector keeps voxels whose validity is at least a threshold (`DEFAULT_VALIDITY`). This
script plays 100 declutter rounds (`symgrasp bench declutter --validity V`) of each shipped
``bingham2d`` model at several thresholds: on *training* objects (``household-train``, seeds
1000–1099, no round shared with the test seeds 0–99), where a threshold may be chosen, and on
the test sets, as a sensitivity analysis of the published table (not to choose by).
"""

from __future__ import annotations

import argparse
import json
import platform
from datetime import datetime, timezone
from pathlib import Path

from common import cpu_model

from symgrasp.benchmark.runner import BenchmarkConfig, percent_with_interval, run_benchmark
from symgrasp.detect.detector import DEFAULT_VALIDITY

MODELS = ("bingham2d-robotiq-2f85", "bingham2d-franka")
THRESHOLDS = (0.02, 0.04, 0.08, 0.15)
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
        "no grasp found | collision |",
        "|---|---|---|---|---|---|---|",
    ]
    for row in rows:
        s = row["summary"]
        default = " (default)" if row["validity"] == DEFAULT_VALIDITY else ""
        text.append(
            f"| {row['model']} | {row['objects']} ({row['seed']}–{row['seed'] + s['rounds'] - 1}) "
            f"| {row['validity']}{default} | {percent_with_interval(s, 'success_ratio')} "
            f"| {percent_with_interval(s, 'clear_ratio')} | {s['outcomes'].get('none_found', 0)} "
            f"| {s['modes'].get('collision', 0)} |"
        )
    return "\n".join(text) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=100, help="rounds per cell (default: 100)")
    parser.add_argument("--workers", type=int, default=2, help="round processes (default: 2)")
    parser.add_argument("--out", default="out/validity_sweep", help="per-cell benchmark folders")
    parser.add_argument("--result", default="benchmarks/results/validity_sweep", help="stem")
    args = parser.parse_args()

    rows = []
    for model in MODELS:
        for objects, seed, purpose in SETS:
            for validity in THRESHOLDS:
                print(f"{model} on {objects}, validity ≥ {validity}")
                config = BenchmarkConfig(
                    model, objects, 5, args.rounds, seed, (("validity_threshold", validity),)
                )
                folder = Path(args.out) / model / objects / str(validity)
                summary = run_benchmark(config, folder, args.workers)
                rows.append({"model": model, "objects": objects, "seed": seed,
                             "purpose": purpose, "validity": validity,
                             "summary": summary})  # fmt: skip
    table = markdown(rows)
    print(table)
    result = {
        "benchmark": "declutter SR / CR of the shipped bingham2d models per validity threshold",
        "command": "PYTHONPATH=src python benchmarks/validity_sweep.py",
        "rounds": args.rounds,
        "default_validity": DEFAULT_VALIDITY,
        "machine": {"cpu": cpu_model(), "python": platform.python_version()},
        "date": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "cells": rows,
    }
    Path(f"{args.result}.json").write_text(json.dumps(result, indent=1) + "\n")
    Path(f"{args.result}.md").write_text(table)


if __name__ == "__main__":
    main()
