"""VGN's network in symgrasp's declutter benchmark, paired with symgrasp's detectors on the same
rounds → experiments/results/peers_declutter.{json,md} and docs/peers.md.

    SYMGRASP_DATA=DIR PYTHONPATH=src python experiments/peers_table.py [--out out/bench/peers] \\
        [--baselines out/bench/table] [--rounds 100] [--workers 1] [--cells HAND/OBJECTS ...] \\
        [--play-only | --collate-only] [--quick [DIR]]

- **VGN's cells**: VGN's network (`symgrasp.peers.vgn`: its public weights, VGN's input, GIGA's
  decoding, best first; docs/peers.md) on Table 1's rounds (round seeds 0…, 5 objects, failure
  diagnosis on): with the Franka hand, the hand VGN was trained for, on ``vgn-pile-test``
  (pile), ``vgn-packed-test`` (packed) and ``large-box`` (pile); with the Robotiq 2F-85 on
  Table 1's Robotiq cells, ``vgn-pile-test`` and ``large-box``. Each in
  ``--out/HAND/vgn/OBJECTS[-packed]`` (``symgrasp bench declutter --model vgn --gripper
  HAND``; a finished cell is read, an unfinished one resumed).
- **Baselines**: the shipped ``bingham2d-HAND`` and ``rotmat6d-HAND`` on the same rounds. They
  are Table 1's cells of their training seed (`symgrasp.benchmark.cells`), which they replay
  round for round (experiments/tests/test_shipped_replay.py): read from
  ``--baselines``, the Table 1 rounds unpacked (``mkdir -p out/bench/table && tar xzf
  experiments/results/declutter_rounds.tar.gz -C out/bench/table``), else played with the
  shipped model into ``--out/HAND/REP/OBJECTS[-packed]``.
- **The table**: per cell, SR and CR with 95 % bootstrap intervals over rounds, VGN minus each
  baseline paired round by round (`symgrasp.benchmark.compare`), VGN's failure modes, and for
  the Franka pile and packed cells the single-view VGN that GIGA published (``PUBLISHED`` of
  declutter_table.py; another simulator and protocol, docs/benchmark.md).

The table also replaces the text between the ``peers-table`` markers of ``--docs``
(docs/peers.md). A campaign plays each cell in a step of its own (``--play-only --cells
HAND/OBJECTS``) and collates at the end (``--collate-only``; experiments/campaigns/peers.toml).
``--quick``: one round of 2 objects on the large box with the Franka hand, its baselines
played, a copy of the page updated.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path
from typing import Any

from common import (
    add_approach_check,
    add_mode_options,
    add_result_option,
    add_table1_options,
    table1_rounds,
    update_page,
)
from declutter_table import PUBLISHED
from scripts import command_line, cpu_model, parse_args, run_main, write_result

from symgrasp.benchmark.cells import objects_folder
from symgrasp.benchmark.compare import paired_change, percent_change
from symgrasp.benchmark.runner import percent_with_interval, run_or_reuse, saved_rounds, summarise
from symgrasp.benchmark.seeds import common_rounds
from symgrasp.cli.options import approach_check
from symgrasp.config import BenchmarkConfig, PlannerOptions
from symgrasp.parallel.options import add_parallel_options, parallel_from_args

CELLS = (
    ("franka", "vgn-pile-test", "pile"),
    ("franka", "vgn-packed-test", "packed"),
    ("franka", "large-box", "pile"),
    ("robotiq-2f85", "vgn-pile-test", "pile"),
    ("robotiq-2f85", "large-box", "pile"),
)
"""VGN's cells: hand, object set, scene (module docstring)."""

BASELINES = ("bingham2d", "rotmat6d")
"""symgrasp's detectors VGN is paired with: the shipped models REP-HAND."""

BEGIN, END = "<!-- peers-table: begin -->", "<!-- peers-table: end -->"
"""The markers of ``--docs`` between which the table goes."""


def cell_name(cell: tuple[str, str, str]) -> str:
    """``HAND/OBJECTS`` (``--cells``); the scene follows from the object set."""
    return f"{cell[0]}/{cell[1]}"


def vgn_config(hand: str, objects: str, scene: str, args: argparse.Namespace) -> BenchmarkConfig:
    return BenchmarkConfig(
        model="vgn", objects=objects, scene=scene, num_objects=args.num_objects,
        rounds=args.rounds, options=PlannerOptions(gripper=hand), **approach_check(args),
    )  # fmt: skip


def baseline_rounds(
    rep: str, hand: str, objects: str, scene: str, args: argparse.Namespace, play: bool
) -> tuple[list[dict[str, Any]] | None, str]:
    """The rounds of the shipped ``REP-HAND`` on the cell's rounds and where they come from:
    Table 1's cell in ``--baselines`` when it played the cell's world (objects, scene, objects
    per round, from round seed 0) and holds them all (`table1_rounds`), else its own folder
    under ``--out`` (played when ``play``); None when neither holds them."""
    model = f"{rep}-{hand}"
    world = {"objects": objects, "scene": scene, "num_objects": args.num_objects, "seed": 0,
             **approach_check(args)}  # fmt: skip
    stored, table = table1_rounds(model, objects, scene, args.baselines, args.rounds, world)
    if stored is not None:
        return stored, str(table)
    config = BenchmarkConfig(model=model, objects=objects, scene=scene,
                             num_objects=args.num_objects, rounds=args.rounds,
                             **approach_check(args))  # fmt: skip
    own = args.out / hand / rep / objects_folder(objects, scene)
    if play:
        return run_or_reuse(config, own, parallel_from_args(args)), str(own)
    return saved_rounds(config, own), str(own)


def collate(args: argparse.Namespace, cells: list[tuple[str, str, str]]) -> list[dict[str, Any]]:
    """Every cell's numbers (None for VGN's or a baseline's rounds not played yet)."""
    out = []
    for hand, objects, scene in cells:
        config = vgn_config(hand, objects, scene, args)
        rounds = saved_rounds(config, args.out / hand / "vgn" / objects_folder(objects, scene))
        cell: dict[str, Any] = {"gripper": hand, "objects": objects, "scene": scene}
        if rounds is None:
            out.append({**cell, "waiting": True})
            continue
        cell["vgn"] = summarise(rounds)
        cell["baselines"] = {}
        for rep in BASELINES:
            base, source = baseline_rounds(rep, hand, objects, scene, args, play=False)
            if base is None:
                cell["baselines"][rep] = {"waiting": True, "source": source}
                continue
            ours, theirs = common_rounds(rounds, base)
            cell["baselines"][rep] = {
                "source": source, "summary": summarise(base), "paired_rounds": len(ours),
                "vgn_minus": paired_change(ours, theirs),
            }  # fmt: skip
        published = next(p for name, p, _ in PUBLISHED if name == "VGN (single view)")
        if hand == "franka" and objects.startswith("vgn-"):
            cell["published_vgn_single_view"] = dict(
                zip(("sr", "cr"), published[scene], strict=True)
            )
        out.append(cell)
    return out


def table(cells: list[dict[str, Any]]) -> str:
    head = ("| hand | objects (scene) | VGN SR % | VGN CR % | "
            + " | ".join(f"{rep} SR / CR %" for rep in BASELINES) + " | "
            + " | ".join(f"VGN − {rep} SR / CR" for rep in BASELINES)
            + " | VGN published (GIGA, single view) SR / CR |")  # fmt: skip
    lines = [head, "|" + "---|" * (5 + 2 * len(BASELINES))]
    modes = ["", "VGN's failure modes (`symgrasp.benchmark.failures`):", "",
             "| hand | objects (scene) | executed | modes |", "|---|---|---|---|"]  # fmt: skip
    for c in cells:
        where = f"| {c['gripper']} | {c['objects']} ({c['scene']}) |"
        if c.get("waiting"):
            lines.append(where + " waiting |" + " |" * (2 + 2 * len(BASELINES)))
            continue
        vgn = c["vgn"]
        row = [
            percent_with_interval(vgn, "success_ratio"),
            percent_with_interval(vgn, "clear_ratio"),
        ]
        changes = []
        for rep in BASELINES:
            b = c["baselines"][rep]
            if b.get("waiting"):
                row.append("waiting")
                changes.append("waiting")
                continue
            s = b["summary"]
            row.append(f"{100 * s['success_ratio']:.1f} / {100 * s['clear_ratio']:.1f}")
            changes.append(f"{percent_change(b['vgn_minus']['success_ratio'])} / "
                           f"{percent_change(b['vgn_minus']['clear_ratio'])}")  # fmt: skip
        published = c.get("published_vgn_single_view")
        row += [*changes, f"{published['sr']} / {published['cr']}" if published else "–"]
        lines.append(where + " " + " | ".join(row) + " |")
        found = ", ".join(f"{k} {v}" for k, v in vgn["modes"].items())
        modes.append(f"{where} {vgn['executed']} | {found} |")
    return "\n".join(lines + modes) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/bench/peers"),
                        help="where VGN's cells (and baselines not in --baselines) are played "
                        "(default: %(default)s)")  # fmt: skip
    add_table1_options(parser)
    parser.add_argument("--cells", nargs="+", default=None, metavar="HAND/OBJECTS",
                        choices=[cell_name(c) for c in CELLS],
                        help="the cells to play or collate (default: all: %(choices)s)")  # fmt: skip
    add_mode_options(parser, "play the cells and their baselines, write no result",
                     "play nothing: collate what is there, list what is missing")  # fmt: skip
    parser.add_argument("--docs", type=Path, default=Path("docs/peers.md"),
                        help="page whose text between the peers-table markers is replaced "
                        "(default: %(default)s)")  # fmt: skip
    add_parallel_options(parser, "rounds")
    add_result_option(parser, "peers_declutter")
    add_approach_check(parser)
    args = parse_args(parser, outputs=("out", "baselines", "result", "docs"),
                      quick={"rounds": 1, "num_objects": 2, "cells": ["franka/large-box"]},
                      pages=("docs",))  # fmt: skip
    cells = [c for c in CELLS if args.cells is None or cell_name(c) in args.cells]

    if not args.collate_only:
        for hand, objects, scene in cells:
            config = vgn_config(hand, objects, scene, args)
            folder = args.out / hand / "vgn" / objects_folder(objects, scene)
            print(f"VGN {hand} {objects} ({scene}) → {folder}")
            run_or_reuse(config, folder, parallel_from_args(args))
            for rep in BASELINES:
                baseline_rounds(rep, hand, objects, scene, args, play=True)
    if args.play_only:
        return
    collated = collate(args, cells)
    text = table(collated)
    print(text)
    load = os.getloadavg()[0]
    command = command_line("SYMGRASP_DATA=../shared PYTHONPATH=src")
    update_page(args.docs, BEGIN, END, f"{args.rounds} rounds a cell, collated by `{command}` "
                f"({cpu_model()}, load {load:.1f}; "
                "a round's outcomes do not depend on the load: each is a pure function of its "
                "seed):\n\n" + text)  # fmt: skip
    write_result(
        args.result,
        "VGN's network in symgrasp's declutter benchmark, paired with symgrasp's detectors",
        command,
        collated,
        text,
        rounds=args.rounds,
        num_objects=args.num_objects,
    )


if __name__ == "__main__":
    run_main(main)
