"""The shipped detectors under the field's observations: depth noise, GIGA's side view, both, and
VGN's six views, each paired with today's clean fixed view on the same rounds →
experiments/results/robustness.{json,md} and docs/results.md (between its robustness markers).

    SYMGRASP_DATA=DIR PYTHONPATH=src python experiments/robustness.py [--out out/bench/robustness] \\
        [--baselines out/bench/table] [--models M ...] [--sets OBJECTS:SCENE ...] \\
        [--conditions C ...] [--rounds 100] [--workers 1] [--play-only | --collate-only] \\
        [--quick [DIR]]

- **Cells**: each shipped model of ``--models`` (default the ``bingham2d`` and ``rotmat6d`` of
  both hands) on each set of ``--sets`` (default ``vgn-pile-test`` as a pile and
  ``vgn-packed-test`` packed), ``--rounds`` rounds of 5 objects from round seed 0 with failure
  diagnosis: Table 1's rounds.
- **Conditions** (`CONDITIONS`, ``symgrasp bench declutter --noise --view --views``;
  docs/benchmark.md, "Sensing"): ``clean`` (one noiseless image from the fixed camera: Table
  1's), ``noise`` (the ``dex`` depth noise), ``side`` (GIGA's side view), ``noise-side``
  (both: GIGA's published setting), ``circle6`` (VGN's six views, noiseless). Each condition
  of a cell plays into ``--out/HAND/REP/OBJECTS[-packed]/CONDITION`` (a finished one is read,
  an unfinished one resumed).
- **Clean rounds reused**: a shipped model replays the Table 1 cell of its training seed round
  for round (tests/benchmark/test_benchmark_shipped_replay.py), so its clean rounds are that
  cell's in ``--baselines`` (the Table 1 rounds unpacked: ``mkdir -p out/bench/table && tar
  xzf experiments/results/declutter_rounds.tar.gz -C out/bench/table``) when it recorded the
  same configuration but the model file; otherwise (Table 1 has no Robotiq packed cell) they are
  played into ``--out/…/clean``.
- **The table**: per cell and condition, SR and CR with 95 % bootstrap intervals over rounds,
  the paired change from clean on the rounds both finished (`symgrasp.benchmark.compare`), the
  share of executed grasps whose hand hit something at the pre-grasp or on the way in, and the
  rounds that ended because no grasp was found.

A campaign plays each condition of each cell in a step of one core (``--play-only --models M
--sets S --conditions C``) and collates at the end (``--collate-only``;
experiments/campaigns/robustness.toml). ``--quick``: one round of 2 household-test objects with
the shipped Robotiq model in every condition, its clean rounds played, a copy of the page
updated.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import shutil
from pathlib import Path
from typing import Any

from common import (
    SHIPPED,
    add_mode_options,
    add_result_option,
    add_table1_options,
    table1_rounds,
    update_page,
)

from symgrasp.benchmark.cells import objects_folder
from symgrasp.benchmark.compare import paired_change, percent_change
from symgrasp.benchmark.runner import percent_with_interval, run_or_reuse, saved_rounds, summarise
from symgrasp.benchmark.seeds import common_rounds
from symgrasp.config import BenchmarkConfig
from symgrasp.detect.pretrained import trained_for
from symgrasp.names import PRETRAINED
from symgrasp.parallel.options import add_parallel_options, parallel_from_args
from symgrasp.scripts import cpu_model, parse_args, run_main, write_result

MODELS = ("bingham2d-franka", "rotmat6d-franka", "bingham2d-robotiq-2f85", "rotmat6d-robotiq-2f85")
"""The shipped models measured by default: the paper's detector and its strongest baseline,
for each hand."""
SETS = ("vgn-pile-test:pile", "vgn-packed-test:packed")
"""VGN's test scenes (``OBJECTS:SCENE``)."""
CONDITIONS = {
    "clean": {"noise": "none", "view": "fixed", "views": 1},
    "noise": {"noise": "dex", "view": "fixed", "views": 1},
    "side": {"noise": "none", "view": "side", "views": 1},
    "noise-side": {"noise": "dex", "view": "side", "views": 1},
    "circle6": {"noise": "none", "view": "circle", "views": 6},
}
"""What the cameras see in each condition: `BenchmarkConfig`'s sensing fields."""
CLEAN = "clean"
"""The condition every other one is paired with: Table 1's."""
COLLISIONS = ("pregrasp_collision", "approach_collision")
"""Outcomes of a hand that hit something before it closed (`symgrasp.sim.execute.Outcome`)."""
BEGIN, END = "<!-- robustness-table: begin -->", "<!-- robustness-table: end -->"
"""The markers of ``--docs`` between which the table goes."""


def parse_set(text: str) -> tuple[str, str]:
    """``OBJECTS:SCENE`` → (objects, scene)."""
    objects, _, scene = text.rpartition(":")
    if not objects or scene not in ("pile", "packed"):
        raise argparse.ArgumentTypeError(f"--sets: expected OBJECTS:pile|packed, got {text!r}")
    return objects, scene


def config(
    model: str, objects: str, scene: str, condition: str, args: argparse.Namespace
) -> BenchmarkConfig:
    """The benchmark of ``model`` on the cell's rounds in ``condition``."""
    return BenchmarkConfig(model=model, objects=objects, scene=scene, rounds=args.rounds,
                           num_objects=args.num_objects, **CONDITIONS[condition])  # fmt: skip


def folder(model: str, objects: str, scene: str, condition: str, args: argparse.Namespace) -> Path:
    """Where a condition of a cell plays: ``--out/HAND/REP/OBJECTS[-packed]/CONDITION``."""
    rep, hand = trained_for(model)
    return args.out / hand.name / rep / objects_folder(objects, scene) / condition


def clean_rounds(model: str, objects: str, scene: str, args: argparse.Namespace) -> tuple:
    """The clean rounds of the shipped ``model`` from the Table 1 cell of its training seed in
    ``--baselines`` and that folder, when the cell recorded the clean configuration (but the
    model file, a training run's, which the shipped model replays) and holds every round; else
    (None, its folder)."""
    wanted = json.loads(json.dumps(dataclasses.asdict(config(model, objects, scene, CLEAN, args))))
    ignored = ("model", "rounds", "pictures")
    agree = {k: v for k, v in wanted.items() if k not in ignored}
    return table1_rounds(model, objects, scene, args.baselines, args.rounds, agree)


def rounds_of(model: str, objects: str, scene: str, condition: str, args: argparse.Namespace,
              play: bool) -> tuple[list[dict[str, Any]] | None, Path]:  # fmt: skip
    """A condition's rounds and where they are (clean: Table 1's when it holds them); played
    or resumed when ``play``, else None when not all there."""
    if condition == CLEAN:
        stored, cell = clean_rounds(model, objects, scene, args)
        if stored is not None:
            return stored, cell
    wanted = config(model, objects, scene, condition, args)
    where = folder(model, objects, scene, condition, args)
    if play:
        return run_or_reuse(wanted, where, parallel_from_args(args)), where
    return saved_rounds(wanted, where), where


def counts(rounds: list[dict[str, Any]]) -> dict[str, Any]:
    """A condition's SR and CR with intervals (`summarise`), collisions before closing per
    executed grasp, and the rounds that ended because no grasp was found."""
    summary = summarise(rounds)
    done = [r for r in rounds if "error" not in r]
    collided = sum(summary["outcomes"].get(o, 0) for o in COLLISIONS)
    return {
        **{k: summary[k] for k in ("rounds", "executed", "successes", "errors", "success_ratio",
                                   "clear_ratio", "success_ratio_ci95", "clear_ratio_ci95",
                                   "outcomes", "modes")},
        "presented": summary["objects"],
        "collided": collided,
        "ended_none_found": sum(1 for r in done
                                if r["attempts"] and r["attempts"][-1]["outcome"] == "none_found"),
        "finished_rounds": len(done),
    }  # fmt: skip


def collate(args: argparse.Namespace) -> list[dict[str, Any]]:
    """Every cell and condition: its numbers, or that it is waiting."""
    cells = []
    for model in args.models:
        for objects, scene in args.sets:
            clean, _ = rounds_of(model, objects, scene, CLEAN, args, play=False)
            for condition in args.conditions:
                rounds, where = rounds_of(model, objects, scene, condition, args, play=False)
                cell = {"model": model, "objects": objects, "scene": scene,
                        "condition": condition, **CONDITIONS[condition], "source": str(where)}  # fmt: skip
                if rounds is None:
                    cells.append({**cell, "waiting": True})
                    continue
                cell.update(counts(rounds))
                if clean is not None and condition != CLEAN:
                    cell["minus_clean"] = paired(rounds, clean)
                cells.append(cell)
    return cells


def paired(rounds: list[dict[str, Any]], clean: list[dict[str, Any]]) -> dict[str, Any]:
    """``rounds`` minus ``clean`` on the rounds both finished: SR and CR changes with their
    paired intervals (`paired_change`) and how many rounds were paired."""
    ours, theirs = common_rounds(rounds, clean)
    return {"paired_rounds": len(ours), **paired_change(ours, theirs)}


def table(cells: list[dict[str, Any]]) -> str:
    """Markdown: one row per cell and condition."""
    lines = ["| model | objects (scene) | condition | SR % [95 % CI] | CR % [95 % CI] | "
             "SR − clean [paired 95 %] | CR − clean [paired 95 %] | hit before closing | "
             "rounds ended, no grasp |", "|---|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for c in cells:
        where = f"| `{c['model']}` | {c['objects']} ({c['scene']}) | {c['condition']} |"
        if c.get("waiting"):
            lines.append(where + " waiting |" + " |" * 5)
            continue
        change = c.get("minus_clean")
        lines.append(
            f"{where} {percent_with_interval(c, 'success_ratio')} | "
            f"{percent_with_interval(c, 'clear_ratio')} | "
            + (f"{percent_change(change['success_ratio'])} | "
               f"{percent_change(change['clear_ratio'])} |" if change else "– | – |")
            + f" {c['collided']} of {c['executed']} | {c['ended_none_found']} of "
            f"{c['finished_rounds']} |"
        )  # fmt: skip
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/bench/robustness"),
                        help="where the conditions (and clean rounds not in --baselines) are "
                        "played (default: %(default)s)")  # fmt: skip
    add_table1_options(parser, baselines=": the clean rounds")
    parser.add_argument("--models", nargs="+", choices=PRETRAINED, default=list(MODELS),
                        help="shipped models (default: %(default)s)")  # fmt: skip
    parser.add_argument("--sets", nargs="+", type=parse_set, default=[parse_set(s) for s in SETS],
                        metavar="OBJECTS:SCENE",
                        help="object sets and their scene (default: " + " ".join(SETS) + ")")  # fmt: skip
    parser.add_argument("--conditions", nargs="+", choices=list(CONDITIONS),
                        default=list(CONDITIONS),
                        help="what the cameras see (default: all: %(choices)s; clean is "
                        "always collated, the others' pairing)")  # fmt: skip
    add_mode_options(parser, "play the conditions, write no result",
                     "play nothing: collate what is there, list what is missing")  # fmt: skip
    parser.add_argument("--docs", type=Path, default=Path("docs/results.md"),
                        help="page whose text between the robustness-table markers is replaced "
                        "(default: %(default)s)")  # fmt: skip
    add_parallel_options(parser, "rounds")
    add_result_option(parser, "robustness")
    args = parse_args(parser, outputs=("out", "baselines", "result", "docs"),
                      quick={"rounds": 1, "num_objects": 2, "models": [SHIPPED],
                             "sets": [("household-test", "pile")]},
                      also="a copy of the page")  # fmt: skip
    if args.quick:  # the page's copy, so that its markers are still checked
        shutil.copyfile(parser.get_default("docs"), args.docs)
    if not args.play_only and CLEAN not in args.conditions:
        args.conditions = [CLEAN, *args.conditions]

    if not args.collate_only:
        for model in args.models:
            for objects, scene in args.sets:
                for condition in args.conditions:
                    print(f"{model} on {objects} ({scene}), {condition}")
                    rounds_of(model, objects, scene, condition, args, play=True)
    if args.play_only:
        return
    cells = collate(args)
    text = table(cells)
    print(text, end="")
    load = os.getloadavg()[0]
    update_page(args.docs, BEGIN, END, f"{args.rounds} rounds a cell, collated by `SYMGRASP_DATA=../shared "
                f"PYTHONPATH=src python experiments/robustness.py` ({cpu_model()}, load "
                f"{load:.1f}; a round's outcomes do not depend on the load: each is a pure "
                "function of its seed):\n\n" + text)  # fmt: skip
    write_result(
        args.result,
        "The shipped detectors under depth noise, GIGA's side view, both and VGN's six views, "
        "paired with the clean fixed view on the same rounds",
        "SYMGRASP_DATA=../shared PYTHONPATH=src python experiments/robustness.py",
        cells,
        text,
        rounds=args.rounds,
        num_objects=args.num_objects,
        conditions={name: CONDITIONS[name] for name in args.conditions},
    )


if __name__ == "__main__":
    run_main(main)
