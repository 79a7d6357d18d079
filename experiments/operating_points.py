"""Each shipped `bingham2d` model's operating point, chosen on training objects →
experiments/results/operating_points.{json,md} (and, with ``--write-card``, the model cards'
``symgrasp/detect/models/operating_points.json``).

    PYTHONPATH=src python experiments/operating_points.py [--rounds 200] [--seed 3000000]
        [--out out/decoding] [--workers 2] [--write-card] [--quick [DIR]]

The rule, written before the thin boxes' rounds were played:

1. Candidates per model: the library's defaults (validity 0.08, confidence 15, no forced
   decoding, no fallbacks), ``fallbacks`` 8, ``validity_floor`` 0.02, and both.
2. The thin-box gate: each candidate plays ``--rounds`` rounds of ``thin-boxes-train`` (5 thin
   boxes lying flat, of other sizes than the test box) under symgrasp's protocol; a candidate
   whose SR + CR there falls below the defaults' by an established margin (the paired 95 %
   interval wholly below 0) is out.
3. Of the rest, the one with the highest SR + CR on the hand's choosing rounds wins: the
   Robotiq hand's ``vgn-pile-train`` piles, the Franka hand's ``vgn-packed-train`` packed
   scenes (the scenes of its target; one operating point serves both scenes), the rounds of
   `experiments/decoding.py` (the same folders). A tie goes to the candidate with fewer
   options.

Every cell's rounds are seeds ``--seed`` … ``--seed + rounds − 1``, off the test seeds; the
large box and the test meshes are never played here. The Robotiq pile rows of the defaults and
of ``fallbacks`` 8 were seen before this rule was written (issue 62's first measurements); the
other cells were not. ``--quick`` plays one round of one object per cell.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any

from common import add_decoding_options, write_rounds_archive
from scripts import command_line, parse_args, run_main, write_result

from symgrasp.benchmark.compare import paired_change, percent_change
from symgrasp.benchmark.runner import (
    SR_PLUS_CR,
    BenchmarkConfig,
    percent_with_interval,
    run_or_reuse,
    summarise,
)
from symgrasp.benchmark.seeds import common_rounds
from symgrasp.config import PlannerOptions
from symgrasp.detect.pretrained import shipped_path
from symgrasp.parallel.options import parallel_from_args

MODELS = {  # model: (its choosing rounds' objects and scene, the decoding.py arm prefix)
    "bingham2d-robotiq-2f85": (("vgn-pile-train", "pile"), "robotiq"),
    "bingham2d-franka": (("vgn-packed-train", "packed"), "franka-packed"),
}
CANDIDATES = {  # name: the options over the library's defaults, fewest first
    "base": {},
    "fb8": {"fallbacks": 8},
    "floor02": {"validity_floor": 0.02},
    "fb8-floor02": {"validity_floor": 0.02, "fallbacks": 8},
}
GATE = ("thin-boxes-train", "pile")


def _config(model: str, objects: str, scene: str, options: dict, args) -> BenchmarkConfig:
    return BenchmarkConfig(
        model=model, objects=objects, scene=scene, num_objects=args.num_objects,
        rounds=args.rounds, seed=args.seed,
        options=PlannerOptions(**options),
    )  # fmt: skip


def _total(summary: dict[str, Any]) -> float:
    total = summary["success_ratio"] + summary["clear_ratio"]
    return total if math.isfinite(total) else -math.inf


def choose(rows: list[dict]) -> dict:
    """The rule of the module docstring over one model's ``rows`` (one per candidate, in
    `CANDIDATES` order, the defaults first): the row it picks."""
    passed = [r for r in rows if r["gate_change"] is None or r["gate_change"][SR_PLUS_CR][2] >= 0]
    return max(passed, key=lambda r: (_total(r["choosing"]), -len(r["options"])))


def markdown(rows: list[dict], chosen: dict[str, str]) -> str:
    text = ["| model | candidate | choosing rounds SR % | CR % | SR + CR | thin boxes SR % | CR % "
            "| thin boxes SR + CR − defaults' | passes the gate | chosen |",
            "|---|---|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for r in rows:
        gate = "–" if r["gate_change"] is None else percent_change(r["gate_change"][SR_PLUS_CR])
        passes = r["gate_change"] is None or r["gate_change"][SR_PLUS_CR][2] >= 0
        text.append(
            f"| {r['model']} | {r['candidate']} | "
            f"{percent_with_interval(r['choosing'], 'success_ratio')} | "
            f"{percent_with_interval(r['choosing'], 'clear_ratio')} | "
            f"{100 * _total(r['choosing']):.1f} | "
            f"{percent_with_interval(r['gate'], 'success_ratio')} | "
            f"{percent_with_interval(r['gate'], 'clear_ratio')} | {gate} | "
            f"{'yes' if passes else 'no'} | {'**yes**' if chosen[r['model']] == r['candidate'] else ''} |"
        )
    return "\n".join(text) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_decoding_options(parser, "operating_points", "cell")
    parser.add_argument(
        "--write-card",
        action="store_true",
        help="write the chosen operating points into the shipped models' cards "
        "(src/symgrasp/detect/models/operating_points.json)",
    )
    args = parse_args(
        parser,
        outputs=("out", "result"),
        quick={"rounds": 1, "num_objects": 1, "workers": 1},
        also="every cell",
    )
    if args.write_card and args.quick:
        raise SystemExit("error: --write-card takes a full run's choice, not --quick's")
    parallel = parallel_from_args(args)
    rows, chosen, gates = [], {}, {}
    for model, ((objects, scene), prefix) in MODELS.items():
        played = {}
        for name, options in CANDIDATES.items():
            print(f"{model}: {name}")
            choosing = _config(model, objects, scene, options, args)
            gate = _config(model, *GATE, options, args)
            gate_folder = Path(args.out) / f"thin-{prefix.split('-')[0]}-{name}"
            gates[gate_folder.name] = gate_folder
            played[name] = (
                run_or_reuse(choosing, Path(args.out) / f"{prefix}-{name}", parallel),
                run_or_reuse(gate, gate_folder, parallel),
            )
        base_gate = played["base"][1]
        model_rows = [
            {"model": model, "candidate": name, "options": options,
             "choosing": summarise(played[name][0], args.seed),
             "gate": summarise(played[name][1], args.seed),
             "gate_change": None if name == "base"
             else paired_change(*common_rounds(played[name][1], base_gate))}
            for name, options in CANDIDATES.items()
        ]  # fmt: skip
        for row in model_rows:
            for part in ("choosing", "gate"):
                row[part] = {k: v for k, v in row[part].items() if k != "families"}
        chosen[model] = choose(model_rows)["candidate"]
        rows += model_rows
    table = markdown(rows, chosen)
    print(table)
    command = command_line("PYTHONPATH=src")
    # the choosing rounds are experiments/decoding.py's archive; the gate's are archived here
    write_rounds_archive(Path(f"{args.result}_rounds.tar.gz"), gates)
    if args.write_card:
        cards = {
            model: {
                **CANDIDATES[name],
                "chosen": {
                    "by": "SR + CR on training-object rounds, thin-box gate "
                    "(experiments/operating_points.py)",
                    "objects": MODELS[model][0][0],
                    "rounds": args.rounds,
                    "seed": args.seed,
                    "record": "experiments/results/operating_points.json",
                },
            }
            for model, name in chosen.items()
        }
        card = shipped_path(next(iter(MODELS))).with_name("operating_points.json")
        card.write_text(json.dumps(cards, indent=1) + "\n")
    write_result(
        args.result,
        "each shipped bingham2d model's operating point among the library's defaults, "
        "fallbacks 8, validity floor 0.02 and both: SR + CR on training-object rounds with a "
        "thin-box gate",
        command,
        rows,
        table,
        chosen=chosen,
        rounds=args.rounds,
        seed=args.seed,
        num_objects=args.num_objects,
    )


if __name__ == "__main__":
    run_main(main)
