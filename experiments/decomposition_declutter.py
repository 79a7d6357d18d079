"""Declutter outcomes with each convex decomposition preset of concave bare meshes
→ experiments/results/decomposition_declutter.{json,md}.

    SYMGRASP_DATA=../shared PYTHONPATH=src python experiments/decomposition_declutter.py
        [--presets coacd vhacd-32 vhacd] [--rounds 30] [--workers 2] [--quick [DIR]]

What a decomposition must get right for the benchmark is what the hand meets: where a finger
enters a mug or rests on a rim, how a pile settles. So the presets
(`symgrasp.objects.decomposition.PRESETS`) are compared by declutter rounds, not by volume
alone (``experiments/decomposition.py`` has the IoU). The objects: the visual meshes of
`MESHES`, eight concave training objects of ``vgn-pile-train``, as a folder of bare meshes
(each preset cuts them itself). The rounds: piles of 5 of them, round seeds 3 000 000 +
r (training objects, seeds no other study uses), the shipped detector (`SHIPPED`, at its model
card's operating point, noiseless fixed camera, symgrasp's protocol), every preset on the same
seeds. Per preset: the parts, the wall seconds of a round on one worker (more parts, more
contacts to simulate), SR and CR with bootstrap intervals, and their paired change against the first preset (the reference,
``coacd``: CoACD's defaults, symgrasp's decomposition before) with 95 % intervals from rounds
resampled in pairs. A preset changes the objects' shapes, so a seed's pile settles differently
under each: the pairing shares the objects drawn and their drop poses, not the scene.

The rule, stated before the rounds were played: a preset is at parity with the reference when
the 95 % intervals of both its SR and its CR change hold 0; the default is the preset at parity
that inspects the 50-mesh folder of ``benchmarks/objects.py`` fastest.

``--quick``: 2 rounds of 2 objects of the first 2 meshes, ``coacd-fast`` against ``vhacd-32``
(seconds; numbers meaningless).
"""

from __future__ import annotations

import argparse
import dataclasses
import shutil
import time
from pathlib import Path
from typing import Any

from common import SHIPPED, add_result_option
from scripts import command_line, parse_args, run_main, write_result

from symgrasp.benchmark.compare import paired_change, percent_change
from symgrasp.benchmark.declutter import run_round
from symgrasp.benchmark.runner import ROUND_THREADS, round_record, summarise
from symgrasp.config import ParallelConfig, PlannerOptions
from symgrasp.detect.pretrained import shipped_operating_point
from symgrasp.names import DECOMPOSITIONS
from symgrasp.objects.folder import set_folder
from symgrasp.objects.sets import ObjectSource, resolve
from symgrasp.parallel import Failure, Job, TasksFailed, open_executor, torch_threads
from symgrasp.peers.planners import load_planner

MESHES = (
    "pan_poisson_017",
    "champagne_glass_poisson_001",
    "mug",
    "bowl_poisson_005",
    "GreenCup_800_tex",
    "RedCup_800_tex",
    "Pitcher_800_tex",
    "watering_can_poisson_001",
)
"""Concave objects of ``vgn-pile-train`` (hull volume ≥ 1.25 × mesh volume): a pan, a glass
(the two that cut fastest first, for ``--quick``), a mug, a bowl, cups, a pitcher, a watering
can."""

SEED = 3_000_000
"""The first round's seed."""


def mesh_folder(folder: Path, count: int) -> Path:
    """``folder`` holding the visual meshes of the first ``count`` of `MESHES` as bare OBJ
    files, named after them."""
    folder.mkdir(parents=True, exist_ok=True)
    vgn = set_folder("vgn-pile-train")
    for name in MESHES[:count]:
        shutil.copyfile(vgn / f"{name}_visual.obj", folder / f"{name}.obj")
    return folder


_WORKER: dict[str, Any] = {}


def _setup(source: ObjectSource, options: PlannerOptions) -> None:
    _WORKER["source"] = source
    _WORKER["planner"] = load_planner(SHIPPED, options)


def _round(seed_objects: tuple[int, int]) -> dict[str, Any]:
    seed, objects = seed_objects
    with torch_threads(ROUND_THREADS):
        record = run_round(_WORKER["planner"], _WORKER["source"], objects, seed, diagnose=False)
    return round_record(record)


def play(source: ObjectSource, seeds: list[int], objects: int, workers: int) -> list[dict]:
    """The rounds of ``seeds`` on ``source``'s objects, in seed order."""
    options = PlannerOptions(**shipped_operating_point(SHIPPED))
    job = Job(_round, _setup, (source, options))
    rounds, failed = {}, []
    with open_executor(ParallelConfig(workers=workers)) as executor:
        for (seed, _), result in executor.map(job, [(s, objects) for s in seeds], "rounds"):
            if isinstance(result, Failure):
                failed.append(f"seed {seed}: {result.error}")
            else:
                rounds[seed] = result
    if failed:
        raise TasksFailed(f"{len(failed)} of {len(seeds)} rounds failed; the first, {failed[0]}")
    return [rounds[s] for s in seeds]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--presets", nargs="+", choices=DECOMPOSITIONS, default=["coacd", "vhacd-32", "vhacd"],
        help="presets played, the reference first (default: %(default)s)",
    )  # fmt: skip
    parser.add_argument("--rounds", type=int, default=30, help="rounds (default: %(default)s)")
    parser.add_argument("--meshes", type=int, default=len(MESHES),
                        help="the first N of the meshes (default: all, %(default)s)")  # fmt: skip
    parser.add_argument("--num-objects", type=int, default=5,
                        help="objects per round (default: %(default)s)")  # fmt: skip
    parser.add_argument("--workers", type=int, default=2,
                        help="processes playing rounds (default: %(default)s)")  # fmt: skip
    parser.add_argument("--work", default="out/decomposition_declutter",
                        help="folder of the bare meshes (default: %(default)s)")  # fmt: skip
    add_result_option(parser, "decomposition_declutter")
    args = parse_args(
        parser,
        outputs=("result", "work"),
        quick={"rounds": 2, "meshes": 2, "num_objects": 2, "presets": ["coacd-fast", "vhacd-32"]},
    )
    folder = mesh_folder(Path(args.work) / "meshes", args.meshes)
    seeds = [SEED + r for r in range(args.rounds)]
    cells, played = [], {}
    for preset in args.presets:
        source = dataclasses.replace(resolve(folder), decomposition=preset)
        parts = {obj.name: len(obj.parts) for obj in map(source.load, range(len(source.files)))}
        start = time.perf_counter()
        played[preset] = play(source, seeds, args.num_objects, args.workers)
        seconds = time.perf_counter() - start
        summary = summarise(played[preset])
        cell = {
            "preset": preset,
            "parts": parts,
            "round_seconds": round(seconds * args.workers / args.rounds, 1),
            **{k: summary[k] for k in ("rounds", "objects", "executed", "successes")},
            **{k: summary[k] for k in summary if k.startswith(("success_ratio", "clear_ratio"))},
        }
        if preset != args.presets[0]:
            change = paired_change(played[preset], played[args.presets[0]])
            cell["change"] = {k: change[k] for k in ("success_ratio", "clear_ratio")}
            cell["parity"] = all(low <= 0 <= high for _, low, high in cell["change"].values())
        cells.append(cell)
        print({k: v for k, v in cell.items() if k != "parts"}, flush=True)
    reference = args.presets[0]
    table = f"| preset | parts | s/round | SR % | CR % | ΔSR vs {reference} | "
    table += f"ΔCR vs {reference} | parity |\n|---|---|---|---|---|---|---|---|\n"
    for c in cells:
        change = c.get("change")
        table += (
            f"| {c['preset']} | {sum(c['parts'].values())} | {c['round_seconds']:.0f} | "
            f"{100 * c['success_ratio']:.1f} | {100 * c['clear_ratio']:.1f} | "
            + (
                f"{percent_change(change['success_ratio'])} | "
                f"{percent_change(change['clear_ratio'])} | {'yes' if c['parity'] else 'no'} |\n"
                if change
                else "– | – | reference |\n"
            )
        )
    write_result(
        args.result,
        "declutter outcomes per convex decomposition preset",
        command_line("SYMGRASP_DATA=../shared PYTHONPATH=src"),
        cells,
        table,
        model=SHIPPED,
        meshes=list(MESHES[: args.meshes]),
        seeds=[seeds[0], seeds[-1]],
        num_objects=args.num_objects,
    )
    print(table, end="")


if __name__ == "__main__":
    run_main(main)
