"""Why later epochs of the wide runs strike the table on the approach (issue 36: where a target
is missed, the failure modes say why) → experiments/results/table_strikes.{json,md}.

    SYMGRASP_DATA=DIR PYTHONPATH=src python experiments/table_strikes.py \\
        --models RUN/epoch_001.pt RUN/epoch_008.pt … [--rounds 60] [--work out/table_strikes] \\
        [--quick [DIR]]

Each checkpoint plays the declutter validation's first ``--rounds`` rounds (vgn-pile-train from
round seed 1 000 000, clean, training objects: the selection's rounds) under the approach rule
the final campaign selected with (``--table-clearance`` and ``--surface-clearance`` −2 mm, the
rule before 2026-11-27), its rounds recording every executed pose. Every executed grasp is then
measured where it was executed: the lowest corner of the open hand's boxes above the table
(`symgrasp.sim.collision.hand_boxes`, the hand the labels and the approach check use), the
closing axis' tilt out of the horizontal, the TCP's height, and whether today's rule (the open
hand 1 mm above the table, `TABLE_CLEARANCE`, checked on the executed pose) refuses it: per
outcome, and for the approach collisions by what the hand struck (the table or an object).
Shares carry Wilson 95 % intervals. Looked at, nothing chosen on it. ``--work`` keeps each
checkpoint's rounds: a killed run resumes. ``--quick``: the shipped model, one round.
"""

from __future__ import annotations

import argparse
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np
from common import SHIPPED, add_result_option, wilson
from scripts import command_line, parse_args, run_main, write_result

from symgrasp.benchmark.runner import run_or_reuse
from symgrasp.config import TABLE_CLEARANCE, VALIDATION_OBJECTS, BenchmarkConfig
from symgrasp.detect.pretrained import resolve_model
from symgrasp.model.checkpoint import load_checkpoint, trained_gripper
from symgrasp.sim.collision import SIGNS, hand_boxes, hand_collides
from symgrasp.sim.grippers import GripperSpec
from symgrasp.workspace import TABLE_HEIGHT

OLD_RULE = -0.002
"""The approach rule's clearances [m] the final campaign's selections played with."""

SEED = 1_000_000
"""The selection's first round seed (`symgrasp select --by declutter`)."""


def hand_corners(gripper: GripperSpec) -> np.ndarray:
    """The corners (B·8, 3) of the open hand's boxes in the TCP frame [m]."""
    boxes = hand_boxes(gripper)
    local = SIGNS[None] * boxes.half[:, None]  # (B, 8, 3) along each box's axes
    return (boxes.centre[:, None] + np.einsum("bij,bkj->bki", boxes.rotation, local)).reshape(-1, 3)


def measure(pose: np.ndarray, corners: np.ndarray, gripper: GripperSpec) -> dict[str, Any]:
    """One executed grasp ``pose`` (T_world_tcp): its open hand's lowest point above the table
    [mm], the closing axis' tilt out of the horizontal [°], the TCP's height [mm], and whether
    the table check with today's clearance refuses it."""
    lowest = (corners @ pose[:3, :3].T + pose[:3, 3])[:, 2].min() - TABLE_HEIGHT
    refused = hand_collides(pose[None], gripper, np.zeros((0, 3)),
                            table_tolerance=-TABLE_CLEARANCE)[0]  # fmt: skip
    return {
        "lowest_mm": 1e3 * lowest,
        "tilt_deg": float(np.degrees(np.arcsin(min(1.0, abs(pose[2, 2]))))),
        "tcp_mm": 1e3 * (pose[2, 3] - TABLE_HEIGHT),
        "refused": bool(refused),
    }


def kind(attempt: dict[str, Any]) -> str:
    """The attempt's outcome; an approach collision by what the hand struck."""
    if attempt["outcome"] != "approach_collision":
        return attempt["outcome"]
    return (
        "approach_collision (table)"
        if "table" in attempt["struck"]
        else "approach_collision (object)"
    )


def summarise(measured: list[dict[str, Any]]) -> dict[str, Any]:
    """Medians of the measurements and the refused share (Wilson 95 %) of a group."""
    n, refused = len(measured), sum(m["refused"] for m in measured)
    median = {
        k: float(np.median([m[k] for m in measured])) for k in ("lowest_mm", "tilt_deg", "tcp_mm")
    }
    return {"attempts": n, **{f"median_{k}": v for k, v in median.items()},
            "refused": refused, "refused_pct": 100 * refused / n, "refused_ci95": wilson(refused, n)}  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", nargs="+", default=[SHIPPED],
                        help="checkpoints (or shipped model names) to play (default: %(default)s)")  # fmt: skip
    parser.add_argument(
        "--rounds", type=int, default=60, help="rounds per checkpoint (default: 60)"
    )
    parser.add_argument("--work", default="out/table_strikes",
                        help="folder of each checkpoint's rounds, kept to resume (default: %(default)s)")  # fmt: skip
    add_result_option(parser, "table_strikes")
    args = parse_args(parser, outputs=("work", "result"), quick={"rounds": 1, "models": [SHIPPED]})

    cells = []
    for index, model in enumerate(args.models):
        path = resolve_model(model)
        gripper = trained_gripper(load_checkpoint(path))
        config = BenchmarkConfig(model=str(path.resolve()), objects=VALIDATION_OBJECTS,
                                 rounds=args.rounds, seed=SEED, diagnose=False,
                                 table_clearance=OLD_RULE, surface_clearance=OLD_RULE)  # fmt: skip
        rounds = run_or_reuse(config, Path(args.work) / f"{index:02d}-{Path(model).stem}")
        corners = hand_corners(gripper)
        groups: dict[str, list[dict[str, Any]]] = defaultdict(list)
        for attempt in (a for r in rounds for a in r["attempts"] if a["pose"] is not None):
            groups[kind(attempt)].append(measure(np.array(attempt["pose"]), corners, gripper))
        executed = sum(len(g) for g in groups.values())
        name = f"{path.parent.name}/{path.stem}" if Path(model).is_file() else str(model)
        cells.append({"model": name, "gripper": gripper.name, "rounds": len(rounds),
                      "executed": executed,
                      "outcomes": {k: summarise(groups[k]) for k in sorted(groups)}})  # fmt: skip

    text = ["| model | outcome | attempts | lowest hand point above the table (median) "
            "| closing-axis tilt (median) | TCP height (median) | refused by today's rule |",
            "|---|---|---|---|---|---|---|"]  # fmt: skip
    for c in cells:
        for name, o in c["outcomes"].items():
            lo, hi = o["refused_ci95"]
            text.append(f"| {c['model']} | {name} | {o['attempts']} | {o['median_lowest_mm']:.1f} mm "
                        f"| {o['median_tilt_deg']:.1f}° | {o['median_tcp_mm']:.1f} mm "
                        f"| {o['refused_pct']:.0f} % [{lo:.0f}, {hi:.0f}] |")  # fmt: skip
    table = "\n".join(text) + "\n"
    print(table)
    write_result(
        args.result,
        "executed grasps of the selection's rounds under the old approach rule, by outcome",
        command_line("SYMGRASP_DATA=DIR PYTHONPATH=src"),
        cells,
        table,
        rounds=args.rounds,
        seed=SEED,
        approach_rule_played=OLD_RULE,
        table_clearance_checked=TABLE_CLEARANCE,
    )


if __name__ == "__main__":
    run_main(main)
