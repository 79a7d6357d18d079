"""Physics sanity of VGN-style scenes on real meshes → experiments/results/scene_physics.json.

    SYMGRASP_DATA=../shared PYTHONPATH=src python experiments/scene_physics.py [--scenes 1000]
        [--out experiments/results/scene_physics.json] [--quick [DIR]]

Builds ``--scenes`` settled scenes of each kind (pile from ``vgn-pile-train``, packed from
``vgn-packed-train``, 5 objects drawn per scene as in the benchmark, seeds 0 … scenes − 1)
and counts, over all objects: those dropped for leaving the workspace (pile: drawn but not
kept; packed scenes also keep fewer when VGN's 12 placements run out, counted apart), those
interpenetrating another object or the table deeper than ``PENETRATION`` after settling, and
those still moving (`World.moving_objects`). Rates carry Wilson 95 % intervals.
``--quick`` builds 3 scenes of each kind.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from common import wilson
from scripts import command_line, parse_args, run_main, write_result
from tqdm import tqdm

from symgrasp.objects.sets import resolve
from symgrasp.sim.world import World

PENETRATION = 0.002
"""Contact depth [m] beyond which two settled bodies count as interpenetrating."""

SETS = {"pile": "vgn-pile-train", "packed": "vgn-packed-train"}


def penetrating(world: World) -> set[int]:
    """Objects in a contact deeper than `PENETRATION` (with an object or the table)."""
    deep = set()
    for c in world.data.contact[: world.data.ncon]:
        if c.dist < -PENETRATION:
            deep |= {int(world._geom_object[g]) for g in (c.geom1, c.geom2)} - {-1}
    return deep


def measure(kind: str, scenes: int) -> dict:
    source = resolve(SETS[kind])
    counts = {"drawn": 0, "kept": 0, "penetrating": 0, "moving": 0, "seconds": 0.0}
    parts = []
    for seed in tqdm(range(scenes), desc=f"{kind} scenes", unit="scene"):
        objects = source.draw(5, seed, kind)
        parts += [len(o.parts) for o in objects]
        start = time.perf_counter()
        world = source.scene(kind, objects, seed)
        counts["seconds"] += time.perf_counter() - start
        counts["drawn"] += len(objects)
        counts["kept"] += len(world.objects)
        counts["penetrating"] += len(penetrating(world))
        counts["moving"] += len(world.moving_objects())
    kept = counts["kept"]
    return {
        "scene": kind,
        "objects": SETS[kind],
        "scenes": scenes,
        "objects_drawn": counts["drawn"],
        "objects_kept": kept,
        "objects_not_kept": counts["drawn"] - kept,
        "penetrating": counts["penetrating"],
        "penetrating_pct_ci": wilson(counts["penetrating"], kept),
        "still_moving": counts["moving"],
        "still_moving_pct_ci": wilson(counts["moving"], kept),
        "parts_per_object_mean": round(float(np.mean(parts)), 1),
        "parts_per_object_max": int(max(parts)),
        "seconds_per_scene": round(counts["seconds"] / scenes, 3),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenes", type=int, default=1000, help="scenes per kind (default: 1000)")
    parser.add_argument(
        "--out", default="experiments/results/scene_physics.json", help="result file (JSON)"
    )
    args = parse_args(parser, outputs=("out",), quick={"scenes": 3})
    cells = [measure(kind, args.scenes) for kind in SETS]
    write_result(
        str(args.out).removesuffix(".json"),
        "scene physics on VGN meshes",
        command_line(""),
        cells,
        penetration_m=PENETRATION,
    )
    for cell in cells:
        print(cell)


if __name__ == "__main__":
    run_main(main)
