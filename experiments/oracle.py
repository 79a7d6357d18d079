"""The ceiling of the declutter benchmark (issue 36): the oracle planner, which executes the
scene's training labels, on Table 1's rounds, paired with the shipped detector →
experiments/results/oracle.{json,md} and docs/results.md ("The ceiling").

    SYMGRASP_DATA=DIR PYTHONPATH=src python experiments/oracle.py [--out out/bench/oracle] \\
        [--baselines out/bench/table] [--rounds 100] [--grasps 150] [--directions 16] \\
        [--cells HAND/OBJECTS ...] [--play-only | --collate-only] [--quick [DIR]]

- **The oracle's cells** (``symgrasp bench declutter --model oracle --gripper HAND
  --oracle-grasps G``; `symgrasp.peers.oracle`): per hand, ``vgn-pile-test`` (pile),
  ``vgn-packed-test`` (packed) and ``large-box`` (pile), round seeds 0…, 5 objects, failure
  diagnosis on, each in ``--out/HAND/oracle-gG[-kK]/OBJECTS[-packed]`` (a finished cell is read,
  an unfinished one resumed). Every drawn object needs its own database, scored on demand
  (`symgrasp.data.grasp_db.OnDemandDatabase`), so a pile round takes ≈ 15–20 s and a cell of 100
  rounds ≈ 30 min on one core of the 2-core development machine.
- **The baseline**: the shipped ``bingham2d-HAND`` on the same rounds, Table 1's cell of its
  training seed read from ``--baselines`` (``mkdir -p out/bench/table && tar xzf
  experiments/results/declutter_rounds.tar.gz -C out/bench/table``), else played with the
  oracle's cell into ``--out/HAND/bingham2d/OBJECTS[-packed]`` (Table 1 has no Robotiq packed
  cell); collating plays nothing.
- **The table**: per cell, the rounds the oracle finished (an unfinished cell is collated on
  the rounds it has: a preliminary ceiling, marked so), its SR and CR with 95 % bootstrap
  intervals, the baseline's on the same rounds and oracle − baseline paired round by round
  (`symgrasp.benchmark.compare`), how each one's rounds ended (`end_cause`), the oracle's failure
  modes and its planning seconds per round (the databases made in it included).

``--quick``: one round of 2 objects on the large box with the Franka hand and databases of 10
grasps and 4 directions, its baseline played.
"""

from __future__ import annotations

import argparse
import os
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np
from common import add_approach_check, add_mode_options, add_result_option, add_table1_options
from peers_table import baseline_rounds, cell_name
from scripts import command_line, cpu_model, parse_args, run_main, write_result

from symgrasp.benchmark.cells import objects_folder
from symgrasp.benchmark.compare import paired_change, percent_change
from symgrasp.benchmark.declutter import NONE_FOUND
from symgrasp.benchmark.runner import (
    percent_with_interval,
    read_rounds,
    recorded_config,
    run_or_reuse,
    summarise,
)
from symgrasp.benchmark.seeds import common_rounds
from symgrasp.cli.options import approach_check
from symgrasp.config import TRAINING_DATABASE, BenchmarkConfig, PlannerOptions
from symgrasp.names import ORACLE
from symgrasp.parallel.options import add_parallel_options, parallel_from_args

HANDS = ("robotiq-2f85", "franka")
"""The hands, the paper's first."""

WORLDS = (("vgn-pile-test", "pile"), ("vgn-packed-test", "packed"), ("large-box", "pile"))
"""The object sets and scenes of the cells (Table 1's)."""

CELLS = tuple((hand, objects, scene) for hand in HANDS for objects, scene in WORLDS)
"""The oracle's cells: hand, object set, scene."""

BASELINE = "bingham2d"
"""The detector the oracle is paired with: the shipped ``bingham2d-HAND``."""

CAUSES = ("cleared", "emptied", NONE_FOUND, "two_failures", "max_attempts")
"""How a round ends (`end_cause`)."""


def oracle_config(hand: str, objects: str, scene: str, args: argparse.Namespace) -> BenchmarkConfig:
    """The cell's benchmark, its options as ``bench declutter --model oracle --gripper HAND
    --oracle-grasps G [--oracle-directions K]`` records them."""
    directions = None if args.directions == TRAINING_DATABASE.directions else args.directions
    options = PlannerOptions(gripper=hand, grasps=args.grasps, directions=directions)
    return BenchmarkConfig(
        model=ORACLE, objects=objects, scene=scene, num_objects=args.num_objects,
        rounds=args.rounds, options=options, **approach_check(args),
    )  # fmt: skip


def oracle_folder(hand: str, objects: str, scene: str, args: argparse.Namespace) -> Path:
    """``--out/HAND/oracle-gG[-kK]/OBJECTS[-packed]``."""
    k = "" if args.directions == TRAINING_DATABASE.directions else f"-k{args.directions}"
    return args.out / hand / f"oracle-g{args.grasps}{k}" / objects_folder(objects, scene)


def end_cause(record: dict[str, Any], max_attempts: int, max_failures: int = 2) -> str:
    """Why a round (a ``rounds.jsonl`` record) ended, in `run_round`'s order of checks: no grasp
    found (``none_found``), ``max_failures`` failed grasps in a row (``two_failures``), the
    attempt limit (``max_attempts``), else the table empty: every object lifted (``cleared``)
    or some lost off the table (``emptied``)."""
    attempts = record["attempts"]
    if attempts and attempts[-1]["outcome"] == NONE_FOUND:
        return NONE_FOUND
    tail = attempts[-max_failures:]
    if len(tail) == max_failures and all(a["outcome"] != "success" for a in tail):
        return "two_failures"
    if len(attempts) >= max_attempts:
        return "max_attempts"
    return "cleared" if record["successes"] == record["objects"] else "emptied"


def end_causes(rounds: list[dict[str, Any]], num_objects: int) -> dict[str, Any]:
    """How many of ``rounds`` ended by each of `CAUSES` (``rounds``), the objects they left on
    the table (``left``: what each cause costs the CR), and of the rounds that ended with
    nothing found, those where the planner proposed nothing (``no_grasp``) and those where the
    observed surface rejected every grasp it proposed (``all_rejected``)."""
    causes = [end_cause(r, 2 * num_objects) for r in rounds]
    counted, left = Counter(causes), Counter()
    for cause, r in zip(causes, rounds, strict=True):
        left[cause] += r["objects"] - r["successes"]
    last = [r["attempts"][-1] for c, r in zip(causes, rounds, strict=True) if c == NONE_FOUND]
    return {
        "rounds": {cause: counted[cause] for cause in CAUSES},
        "left": {cause: left[cause] for cause in CAUSES},
        "no_grasp": sum(a["candidates"] == 0 for a in last),
        "all_rejected": sum(a["candidates"] > 0 for a in last),
    }


def collate(args: argparse.Namespace, cells: list[tuple[str, str, str]]) -> list[dict[str, Any]]:
    """Every cell's numbers on the rounds its oracle finished (none: ``waiting``)."""
    out = []
    for hand, objects, scene in cells:
        folder = oracle_folder(hand, objects, scene, args)
        config = oracle_config(hand, objects, scene, args)
        cell: dict[str, Any] = {"gripper": hand, "objects": objects, "scene": scene,
                                "folder": str(folder)}  # fmt: skip
        recorded = recorded_config(folder)
        if recorded is not None and recorded != config.record():
            raise SystemExit(f"error: {folder} holds another benchmark than {config}")
        done = read_rounds(folder / "rounds.jsonl")
        rounds = [done[s] for s in sorted(done) if s < args.rounds and "error" not in done[s]]
        if not rounds:
            out.append({**cell, "waiting": True})
            continue
        cell["rounds"] = len(rounds)
        cell["planned"] = args.rounds
        cell["oracle"] = summarise(rounds)
        cell["oracle_ends"] = end_causes(rounds, args.num_objects)
        planning = [sum(a["planning_s"] for a in r["attempts"]) for r in rounds]
        cell["oracle_planning_s_per_round"] = {
            "median": float(np.median(planning)), "max": float(np.max(planning)),
        }  # fmt: skip
        base, source = baseline_rounds(BASELINE, hand, objects, scene, args, play=False)
        if base is not None:
            ours, theirs = common_rounds(rounds, base)
            cell["baseline"] = {
                "model": f"{BASELINE}-{hand}", "source": source, "paired_rounds": len(ours),
                "summary": summarise(theirs), "ends": end_causes(theirs, args.num_objects),
                "oracle_minus": paired_change(ours, theirs),
            }  # fmt: skip
        out.append(cell)
    return out


def ends(counted: dict[str, Any]) -> str:
    """`end_causes` as ``rounds by cause (objects left by cause); nothing found: proposed
    nothing + all rejected``."""
    rounds = " / ".join(str(v) for v in counted["rounds"].values())
    left = " / ".join(str(v) for v in counted["left"].values())
    return f"{rounds} ({left}); {counted['no_grasp']} + {counted['all_rejected']}"


def table(cells: list[dict[str, Any]]) -> str:
    lines = [
        f"| hand | objects (scene) | rounds | oracle SR % | oracle CR % | {BASELINE} SR / CR % "
        f"(same rounds) | oracle − {BASELINE} SR / CR | oracle's rounds ended | {BASELINE}'s "
        "| oracle s/round (median) |",
        "|" + "---|" * 10,
    ]
    modes = ["", f"Rounds ended: {' / '.join(CAUSES)} (objects those rounds left on the "
             "table); of the rounds that ended with nothing found, those where the planner "
             "proposed nothing + those where the observed surface rejected all it proposed.",
             "", "The oracle's grasps by failure mode (`symgrasp.benchmark.failures`):", "",
             "| hand | objects (scene) | executed | modes |", "|---|---|---|---|"]  # fmt: skip
    for c in cells:
        where = f"| {c['gripper']} | {c['objects']} ({c['scene']}) |"
        if c.get("waiting"):
            lines.append(where + " waiting |" + " |" * 7)
            continue
        o = c["oracle"]
        shown = f"{c['rounds']}" + ("" if c["rounds"] == c["planned"] else f" of {c['planned']}")
        row = [shown, percent_with_interval(o, "success_ratio"),
               percent_with_interval(o, "clear_ratio")]  # fmt: skip
        b = c.get("baseline")
        if b is None:
            row += ["–", "–"]
        else:
            s, d = b["summary"], b["oracle_minus"]
            row += [f"{100 * s['success_ratio']:.1f} / {100 * s['clear_ratio']:.1f}",
                    f"{percent_change(d['success_ratio'])} / {percent_change(d['clear_ratio'])}"]  # fmt: skip
        row.append(ends(c["oracle_ends"]))
        row.append("–" if b is None else ends(b["ends"]))
        row.append(f"{c['oracle_planning_s_per_round']['median']:.0f}")
        lines.append(where + " " + " | ".join(row) + " |")
        found = ", ".join(f"{k} {v}" for k, v in o["modes"].items())
        modes.append(f"{where} {o['executed']} | {found} |")
    return "\n".join(lines + modes) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/bench/oracle"),
                        help="where the oracle's cells (and baselines not in --baselines) are "
                        "played (default: %(default)s)")  # fmt: skip
    add_table1_options(parser)
    parser.add_argument("--grasps", type=int, default=TRAINING_DATABASE.grasps,
                        help="held grasps per object database (default: %(default)s, the "
                        "shipped models' training data)")  # fmt: skip
    parser.add_argument(
        "--directions",
        type=int,
        default=TRAINING_DATABASE.directions,
        help="directions of each database's score (default: %(default)s)",
    )
    parser.add_argument("--cells", nargs="+", default=None, metavar="HAND/OBJECTS",
                        choices=[cell_name(c) for c in CELLS],
                        help="the cells to play or collate (default: all: %(choices)s)")  # fmt: skip
    add_mode_options(parser, "play the cells, write no result",
                     "play nothing: collate the rounds that are there (an unfinished cell on "
                     "those it has)")  # fmt: skip
    add_parallel_options(parser, "rounds")
    add_result_option(parser, "oracle")
    add_approach_check(parser)
    args = parse_args(parser, outputs=("out", "baselines", "result"),
                      quick={"rounds": 1, "num_objects": 2, "grasps": 10, "directions": 4,
                             "cells": ["franka/large-box"]})  # fmt: skip
    cells = [c for c in CELLS if args.cells is None or cell_name(c) in args.cells]

    if not args.collate_only:
        for hand, objects, scene in cells:
            folder = oracle_folder(hand, objects, scene, args)
            print(f"oracle {hand} {objects} ({scene}) → {folder}")
            run_or_reuse(
                oracle_config(hand, objects, scene, args), folder, parallel_from_args(args)
            )
            baseline_rounds(BASELINE, hand, objects, scene, args, play=True)  # if not Table 1's
    if args.play_only:
        return
    collated = collate(args, cells)
    text = table(collated)
    print(text)
    write_result(
        args.result,
        "The oracle planner (the scene's training labels) in the declutter benchmark, paired "
        "with the shipped detector",
        command_line("SYMGRASP_DATA=../shared PYTHONPATH=src"),
        collated,
        f"{cpu_model()}, load {os.getloadavg()[0]:.1f}\n\n" + text,
        rounds=args.rounds,
        num_objects=args.num_objects,
        grasps=args.grasps,
        directions=args.directions,
    )


if __name__ == "__main__":
    run_main(main)
