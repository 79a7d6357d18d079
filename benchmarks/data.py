"""Cost and quality of dataset generation → benchmarks/results/data.json.

    PYTHONPATH=src python benchmarks/data.py [--pool 4] [--scenes 100] [--workers 2] \
        [--validate 100] [--out benchmarks/results/data.json] [--quick [DIR]]

Measures, on a few objects and at most a few hundred scenes (the 2 000-scene target is
extrapolated from them, as stated in the JSON):

- seconds per object database (``--grasps`` settled grasps scored in ``--directions``
  directions, by default the default configuration's 300 and 32), per gripper, each built
  alone in this process;
- seconds per labelled scene with ``--workers`` processes (databases cached), wall and per
  worker; labelled voxels per scene; grasp survival after the collision check;
- the physics validation: success rate of labelled grasps against random grasps
  (:func:`symgrasp.data.validate.validate_labels`).

``--quick`` builds small databases (three Robotiq, one Franka) and labels four scenes in this
process.
"""

from __future__ import annotations

import argparse
import json
import shutil
import statistics
import tempfile
import time
from datetime import datetime, timezone
from pathlib import Path

import lab  # noqa: F401  (puts the checkout's root on sys.path, for experiments.scripts)
import torch

from experiments.scripts import command_line, machine, parse_args, run_main
from symgrasp.config import DatabaseConfig, ParallelConfig, SceneConfig
from symgrasp.data.card import dataset_card
from symgrasp.data.generate import generate
from symgrasp.data.grasp_db import cached_database
from symgrasp.data.scenes import scene_pool
from symgrasp.sim.grippers import get_gripper
from symgrasp.sim.render import make_renderer

TARGET_SCENES, TARGET_MINUTES, DEFAULT_POOL = 2000, 60.0, SceneConfig().pool_size


def _databases(cfg: SceneConfig, root: Path, n: int) -> dict:
    times, sizes = [], []
    hand = get_gripper(cfg.gripper)
    for k, obj in enumerate(scene_pool(cfg).objects[:n]):
        start = time.perf_counter()
        db = cached_database(obj, hand, root / "db", cfg.database, seed=k)
        times.append(time.perf_counter() - start)
        sizes.append(int(db.held.sum()))
        print(f"{cfg.gripper} {obj.name}: {times[-1]:.1f} s, {sizes[-1]} held of {db.candidates}")
    return {
        "objects": n,
        "seconds_per_database_median": statistics.median(times),
        "seconds_per_database": times,
        "held_grasps_per_database": sizes,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pool", type=int, default=4, help="objects (databases) to build")
    parser.add_argument("--franka", type=int, default=1, help="Franka databases to time")
    parser.add_argument("--scenes", type=int, default=100, help="scenes to generate")
    parser.add_argument("--workers", type=int, default=2, help="worker processes")
    parser.add_argument("--validate", type=int, default=100, help="physics trials")
    parser.add_argument("--grasps", type=int, default=300, help="settled grasps per database")
    parser.add_argument("--directions", type=int, default=32, help="disturbance directions")
    parser.add_argument("--out", default="benchmarks/results/data.json", help="result file")
    quick = {"pool": 3, "scenes": 4, "workers": 1, "validate": 4, "grasps": 10, "directions": 4}
    args = parse_args(parser, outputs=("out",), quick=quick)
    torch.set_num_threads(1)
    tmp = Path(tempfile.mkdtemp(prefix="symgrasp_data_bench_"))
    result: dict = {
        "command": command_line(""),
        "date": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "depth_renderer": make_renderer().name,
    }
    try:
        database = DatabaseConfig(grasps=args.grasps, directions=args.directions)
        robotiq = SceneConfig(gripper="robotiq-2f85", pool_size=args.pool, database=database)
        franka = SceneConfig(gripper="franka", pool_size=args.pool, database=database)
        result["database"] = {
            "robotiq-2f85": _databases(robotiq, tmp / "robotiq", args.pool),
            "franka": _databases(franka, tmp / "franka", args.franka),
        }
        start = time.perf_counter()
        generate(
            tmp / "robotiq", robotiq, args.scenes, 0, True, ParallelConfig(workers=args.workers)
        )
        wall = time.perf_counter() - start
        card = dataset_card(tmp / "robotiq", validate=args.validate, seed=0)
        per_scene = wall / args.scenes
        db_median = result["database"]["robotiq-2f85"]["seconds_per_database_median"]
        minutes = (DEFAULT_POOL * db_median / args.workers + TARGET_SCENES * per_scene) / 60
        result["scenes"] = {
            "gripper": "robotiq-2f85",
            "scenes": args.scenes,
            "workers": args.workers,
            "wall_seconds": wall,
            "seconds_per_scene_wall": per_scene,
            "seconds_per_scene_per_worker": per_scene * args.workers,
            "labelled_voxels_per_scene_mean": card["mean_per_scene"]["valid_voxels"],
            "rotation_targets_per_scene_mean": card["mean_per_scene"]["targets"],
            "grasp_survival_rate": card["grasp_survival_rate"],
            "objects_per_scene_mean": card["mean_per_scene"]["objects"],
            "score_histogram": card["score_histogram"],
            "targets_per_voxel": card["targets_per_voxel"],
        }
        result["label_validation"] = card.get("label_validation")
        result["target_2000_scenes"] = {
            "extrapolated_minutes": minutes,
            "target_minutes": TARGET_MINUTES,
            "how": f"{DEFAULT_POOL} default databases × median database time / {args.workers} "
            f"workers + {TARGET_SCENES} × measured wall seconds per scene with {args.workers} "
            "workers (extrapolated, not run)",
            "met": minutes <= TARGET_MINUTES,
        }
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    result["machine"] = machine()
    Path(args.out).write_text(json.dumps(result, indent=1) + "\n")
    print(
        json.dumps(
            {k: result[k] for k in ("scenes", "label_validation", "target_2000_scenes")}, indent=1
        )
    )


if __name__ == "__main__":
    run_main(main)
