"""Why the detectors leave thin objects lying flat on the table, and what the databases'
offset range has to do with it (issue 36) → experiments/results/thin_objects.{json,md}.

    SYMGRASP_DATA=DIR PYTHONPATH=src nice -n 10 python experiments/thin_objects.py \\
        [--objects NAME ...] [--offsets LO HI LO HI ...] [--scenes 8] [--quick [DIR]]

The objects are those of the retraining campaign's pool (``--object-set``, ``--pool-size``,
pool seed 0, as ``symgrasp data generate`` draws it: the same scaled meshes), the hand
``--gripper``. Two measurements per object, by physics and by the labels' own check:

- **From above, lying flat.** The object alone, dropped on the table (a one-object pile,
  seed 0); a top-down grasp over the centre of its footprint, closing across the footprint's
  narrow axis, with the TCP ``h`` above the table for each ``h`` of `HEIGHTS`: does the open
  hand clear the table by the labels' check (`symgrasp.sim.collision.hand_collides`, the
  dataset's clearance), and what does `symgrasp.sim.execute.execute_grasp` do with it?
- **The labels a database gives it.** Its grasp database (``--grasps`` held grasps, K = 16,
  seed = its pool index, `symgrasp.data.grasp_db.build_database`) for each TCP offset range of
  ``--offsets`` (`DatabaseConfig.offset`: the TCP's offset along the approach from the contacts'
  midpoint), moved into ``--scenes`` one-object pile scenes (seeds 0, 1, …) and collision-
  checked as a training scene is (`symgrasp.data.scenes.scene_grasps`): the share of its held
  grasps kept, and their mean score along gravity.

Looked at, nothing chosen on it: a change of the databases is to be read by the oracle on
training-object rounds (``symgrasp bench declutter --model oracle --oracle-offset``) before a
dataset is made of it. ``--quick``: the first object of a two-object procedural pool, two
heights, tiny databases, one scene.
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from typing import Any

import numpy as np
from common import add_result_option
from scripts import command_line, parse_args, run_main, write_result
from tqdm import tqdm

from symgrasp.config import TRAINING_DATABASE, SceneConfig
from symgrasp.data.grasp_db import build_database
from symgrasp.data.scenes import scene_grasps, scene_pool
from symgrasp.sim.collision import hand_collides
from symgrasp.sim.execute import execute_grasp
from symgrasp.sim.grippers import get_gripper
from symgrasp.workspace import TABLE_HEIGHT

HEIGHTS = np.round(np.arange(0.0, 0.0301, 0.003), 3)
"""TCP heights [m] above the table of the top-down grasps."""

OBJECTS = ["cellphone_poisson_031", "banana_poisson_002", "tape_poisson_005",
           "hammer_poisson_004", "avocado_poisson_001", "sugar_box", "krylon_crystal_clear"]  # fmt: skip
"""Thin objects the retrained detector left on the table (docs/results.md), and three it
clears, for contrast."""


def top_down(obj_pose: np.ndarray, mesh: Any) -> tuple[np.ndarray, float, float]:
    """The top-down grasp's rotation (3, 3) and footprint centre, closing across the object's
    narrow horizontal axis; and the object's top height [m] above the table and narrow width."""
    verts = mesh.vertices @ obj_pose[:3, :3].T + obj_pose[:3, 3]
    xy = verts[:, :2]
    centre = xy.mean(axis=0)
    _, axes = np.linalg.eigh(np.cov((xy - centre).T))
    e_z = np.r_[axes[:, 0], 0.0]
    e_x = np.array([0.0, 0.0, -1.0])
    R = np.stack([e_x, np.cross(e_z, e_x), e_z], axis=1)
    T = np.eye(4)
    T[:3, :3], T[:2, 3] = R, centre
    return T, float(verts[:, 2].max() - TABLE_HEIGHT), float(np.ptp((xy - centre) @ axes[:, 0]))


def from_above(cfg: SceneConfig, source: Any, obj: Any, heights: np.ndarray) -> dict[str, Any]:
    hand = get_gripper(cfg.gripper)
    world = source.scene("pile", [obj], seed=0, gripper=hand)
    state = world.snapshot()
    T, top, width = top_down(world.object_poses()[0], obj.mesh())
    trials = []
    for h in heights:
        T[2, 3] = TABLE_HEIGHT + h
        free = not hand_collides(T[None], hand, np.zeros((0, 3)), tolerance=-cfg.clearance)[0]
        world.restore(state)
        outcome = execute_grasp(world, T, remove=False).outcome.value
        trials.append({"tcp_above_table_m": float(h), "labels_check_free": bool(free),
                       "physics": outcome})  # fmt: skip
    return {"top_above_table_m": top, "narrow_width_m": width, "trials": trials}


def database_labels(
    cfg: SceneConfig,
    source: Any,
    k: int,
    obj: Any,
    offsets: list[tuple[float, float]],
    scenes: int,
) -> list[dict[str, Any]]:
    hand = get_gripper(cfg.gripper)
    worlds = [source.scene("pile", [obj], seed=s) for s in range(scenes)]
    worlds = [w for w in worlds if w.objects]
    cells = []
    for offset in offsets:
        database = dataclasses.replace(cfg.database, offset=offset)
        start = time.perf_counter()
        db = build_database(obj, hand, database, seed=k)
        seconds = time.perf_counter() - start
        kept, scores = [], []
        for s, w in enumerate(worlds):
            g = scene_grasps(w.objects, w.object_poses(), [db], cfg, hand,
                             np.random.default_rng(s))  # fmt: skip
            kept.append(float((~g["collides"]).mean()))
            scores += g["score"][~g["collides"]].tolist()
        cells.append({"offset_m": list(offset), "held": int(db.held.sum()),
                      "closures": len(db.held), "scenes": len(worlds),
                      "kept_share": float(np.mean(kept)),
                      "kept_mean_score": float(np.mean(scores)) if scores else None,
                      "seconds": seconds})  # fmt: skip
    return cells


def table(cells: list[dict[str, Any]]) -> str:
    heights = [t["tcp_above_table_m"] for t in cells[0]["from_above"]["trials"]]
    text = [
        "Top-down grasps over an object lying alone on the table, TCP h above it: the labels' "
        "collision check (free or hits the table) / the physics outcome.",
        "",
        "| object | top, width [mm] | " + " | ".join(f"{1000 * h:.0f} mm" for h in heights) + " |",
        "|---|---|" + "---|" * len(heights),
    ]
    for c in cells:
        a = c["from_above"]
        marks = [("free" if t["labels_check_free"] else "hits") + " / " + t["physics"]
                 for t in a["trials"]]  # fmt: skip
        text.append(f"| {c['object']} | {1000 * a['top_above_table_m']:.0f}, "
                    f"{1000 * a['narrow_width_m']:.0f} | " + " | ".join(marks) + " |")  # fmt: skip
    text += ["", "Its database's held grasps kept in its one-object scenes, per offset range:", "",
             "| object | offset [cm] | held / closures | kept % | kept grasps' mean score |",
             "|---|---|---|---|---|"]  # fmt: skip
    for c in cells:
        for d in c["database"]:
            score = "–" if d["kept_mean_score"] is None else f"{d['kept_mean_score']:.2f}"
            lo, hi = (100 * v for v in d["offset_m"])
            text.append(f"| {c['object']} | {lo:g}, {hi:g} | {d['held']} / {d['closures']} | "
                        f"{100 * d['kept_share']:.1f} | {score} |")  # fmt: skip
    return "\n".join(text) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--objects", nargs="*", default=OBJECTS,
                        help="pool objects by name (default: %(default)s; none: the pool's first)")  # fmt: skip
    parser.add_argument("--object-set", default="vgn-pile-train,vgn-packed-train",
                        help="the pool's object set (default: %(default)s)")  # fmt: skip
    parser.add_argument("--pool-size", type=int, default=417,
                        help="the pool's size, pool seed 0 (default: %(default)s)")  # fmt: skip
    parser.add_argument("--gripper", default="robotiq-2f85", help="the hand (default: %(default)s)")
    parser.add_argument("--grasps", type=int, default=TRAINING_DATABASE.grasps,
                        help="held grasps per database (default: %(default)s)")  # fmt: skip
    parser.add_argument("--offsets", type=float, nargs="+", default=[-0.01, 0.03, -0.03, 0.03],
                        help="TCP offset ranges [m], LO HI pairs (default: %(default)s: the "
                        "datasets' and one reaching 3 cm towards the tips)")  # fmt: skip
    parser.add_argument("--scenes", type=int, default=8,
                        help="one-object pile scenes per database (default: %(default)s)")  # fmt: skip
    parser.add_argument(
        "--heights",
        type=int,
        default=len(HEIGHTS),
        help="how many of the TCP heights 0, 3, … 30 mm to try (default: all)",
    )
    add_result_option(parser, "thin_objects")
    args = parse_args(
        parser,
        outputs=("result",),
        quick={
            "objects": [],
            "object_set": "blocks",
            "pool_size": 2,
            "grasps": 10,
            "scenes": 1,
            "heights": 2,
        },
    )
    if len(args.offsets) % 2:
        parser.error(f"--offsets takes LO HI pairs, got {len(args.offsets)} numbers")
    offsets = [tuple(args.offsets[i : i + 2]) for i in range(0, len(args.offsets), 2)]
    database = dataclasses.replace(TRAINING_DATABASE, grasps=args.grasps)
    cfg = SceneConfig(object_set=args.object_set, pool_size=args.pool_size,
                      gripper=args.gripper, database=database)  # fmt: skip
    resolved = scene_pool(cfg)  # the object set resolved once, for every object and scene
    pool = resolved.objects
    names = [o.name for o in pool]
    unknown = [n for n in args.objects if n not in names]
    if unknown:
        parser.error(f"--objects: not in the pool: {', '.join(unknown)}")
    chosen = [names.index(n) for n in args.objects] or [0]
    cells = []
    for k in tqdm(chosen, desc="objects"):
        cells.append({"object": names[k], "pool_index": k,
                      "from_above": from_above(cfg, resolved.source, pool[k], HEIGHTS[: args.heights]),
                      "database": database_labels(cfg, resolved.source, k, pool[k], offsets, args.scenes)})  # fmt: skip
    text = table(cells)
    print(text)
    write_result(
        args.result,
        "thin objects lying flat: top-down grasps by height, and the labels of two offset ranges",
        command_line("SYMGRASP_DATA=DIR PYTHONPATH=src nice -n 10"),
        cells,
        text,
        object_set=args.object_set,
        pool_size=args.pool_size,
        gripper=args.gripper,
        grasps=args.grasps,
        clearance_m=cfg.clearance,
    )


if __name__ == "__main__":
    run_main(main)
