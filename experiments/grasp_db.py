"""Grasp databases on VGN's meshes: cost, yield, and what more grasps and score directions buy
→ experiments/results/grasp_db.json.

    SYMGRASP_DATA=../shared PYTHONPATH=src python experiments/grasp_db.py [--objects 8]
        [--grasps 300] [--direction-grasps 15] [--scenes 20] [--out ...] [--quick [DIR]]

For the first ``--objects`` objects of the training pool of ``vgn-pile-train,vgn-packed-train``
(pool seed 0, the pool's scales) and each gripper, all through `build_database` itself:

- **Cost and yield.** The candidate grasps, their closures and which ones hold do not depend
  on the number of score directions K (the ramps draw no random numbers), and a database of
  ``n`` grasps is the first ``n`` held grasps of a larger one with the same seed. So one
  build with ``--grasps`` and K = 4 gives the yield (held / closed), the closures' cost
  and every smaller database; ramps are timed apart (a wrapper around `pull_out_forces`).
- **Directions.** The first ``--direction-grasps`` held grasps are scored with K = 8, 16, 32
  and 64 (`fibonacci_directions`); each smaller K is read at the 64 directions by the
  interpolation the scene labels use (`interpolate`) and compared with the score measured
  there. The same grasps scored with a 0.1 s ramp instead of 0.3 s tell what a faster ramp
  changes.
- **Grasps.** ``--scenes`` labelled scenes (`make_scene_record`, VGN's pile and packed
  scenes) built with databases cut to 50, 100, 200 and 300 grasps: labelled voxels and
  rotation targets per scene, the coverage the training labels get.

``--quick`` uses one object, 3 grasps, 1 direction grasp and one scene.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from common import prefix
from scripts import command_line, parse_args, run_main, write_result
from tqdm import tqdm

from symgrasp.config import DatabaseConfig, SceneConfig
from symgrasp.data import grasp_db
from symgrasp.data.directions import fibonacci_directions, interpolate
from symgrasp.data.grasp_db import GraspDatabase, build_database
from symgrasp.data.scenes import make_scene_record, scene_pool
from symgrasp.names import GRIPPERS
from symgrasp.sim.grippers import get_gripper

OBJECTS = "vgn-pile-train,vgn-packed-train"
DIRECTIONS = (8, 16, 32, 64)
FAST_RAMP = 0.1
"""The faster ramp [s] compared with the default 0.3 s."""
GRASP_COUNTS = (50, 100, 200, 300)


class RampClock:
    """Counts and times the force ramps `build_database` runs."""

    def __init__(self) -> None:
        self.calls, self.seconds = 0, 0.0
        self._ramps = grasp_db.pull_out_forces

    def __call__(self, world, index, directions, *args) -> np.ndarray:
        start = time.perf_counter()
        forces = self._ramps(world, index, directions, *args)
        self.seconds += time.perf_counter() - start
        self.calls += len(directions)
        return forces


def timed_build(obj, gripper, cfg: DatabaseConfig, seed: int) -> tuple[GraspDatabase, dict]:
    """The database and what it cost: seconds in all, in ramps, ramps run."""
    clock = RampClock()
    grasp_db.pull_out_forces = clock
    try:
        start = time.perf_counter()
        db = build_database(obj, gripper, cfg, seed)
        seconds = time.perf_counter() - start
    finally:
        grasp_db.pull_out_forces = clock._ramps
    return db, {"seconds": seconds, "ramp_seconds": clock.seconds, "ramps": clock.calls}


def direction_errors(scores: dict[int, np.ndarray], fast: np.ndarray) -> dict:
    """Errors of each K's interpolated score against the score measured at the 64 reference
    directions, and of the fast ramp's score, over held grasps × directions."""
    ref_dirs = fibonacci_directions(DIRECTIONS[-1])
    ref = scores[DIRECTIONS[-1]]
    out = {}
    for k, score in scores.items():
        if k == DIRECTIONS[-1]:
            continue
        dirs = fibonacci_directions(k)
        read = np.stack([interpolate(score, dirs, d) for d in ref_dirs], axis=-1)
        out[f"K={k}"] = _errors(read - ref)
    out[f"ramp {FAST_RAMP} s"] = _errors(fast - ref)
    return out


def _errors(diff: np.ndarray) -> dict:
    a = np.abs(diff).ravel()
    return {
        "mean_abs": round(float(a.mean()), 4),
        "p90_abs": round(float(np.quantile(a, 0.9)), 4),
        "share_over_0.1": round(float((a > 0.1).mean()), 4),
        "values": int(a.size),
    }


def measure(gripper: str, args: argparse.Namespace) -> dict:
    cfg = SceneConfig(
        object_set=OBJECTS,
        gripper=gripper,
        pool_size=args.objects,
        database=DatabaseConfig(grasps=args.grasps, directions=4),
    )
    pool, hand = scene_pool(cfg), get_gripper(cfg.gripper)
    per_object, databases, scores, fast = [], [], {k: [] for k in DIRECTIONS}, []
    for k, obj in enumerate(tqdm(pool.objects, desc=f"{gripper} databases", unit="object")):
        db, cost = timed_build(obj, hand, cfg.database, seed=k)
        databases.append(db)
        held = int(db.held.sum())
        closure_s = cost["seconds"] - cost["ramp_seconds"]
        row = {
            "object": obj.name,
            "parts": len(obj.parts),
            "closures": db.candidates,
            "held": held,
            "yield": round(held / max(db.candidates, 1), 3),
            "closure_seconds_per_closure": round(closure_s / max(db.candidates, 1), 4),
            "seconds_per_ramp": round(cost["ramp_seconds"] / max(cost["ramps"], 1), 5),
        }
        g = args.direction_grasps
        runs = {}
        for K in DIRECTIONS:
            runs[K] = timed_build(obj, hand, DatabaseConfig(grasps=g, directions=K), seed=k)
        fast_db, fast_cost = timed_build(
            obj, hand, DatabaseConfig(grasps=g, directions=64, ramp_time=FAST_RAMP), seed=k
        )
        poses = runs[DIRECTIONS[-1]][0].T_object_tcp
        assert all(np.array_equal(r[0].T_object_tcp, poses) for r in runs.values())
        for K, (small, _) in runs.items():
            scores[K].append(small.score[small.held])
        fast.append(fast_db.score[fast_db.held])
        row["seconds_per_ramp_by_K"] = {
            K: round(c["ramp_seconds"] / max(c["ramps"], 1), 5) for K, (_, c) in runs.items()
        }
        row["seconds_per_ramp_fast"] = round(
            fast_cost["ramp_seconds"] / max(fast_cost["ramps"], 1), 5
        )
        per_object.append(row)
        print(row)

    coverage = []
    for n in GRASP_COUNTS if not args.quick else (args.grasps,):
        cut = [prefix(db, n) for db in databases]
        voxels, targets = [], []
        for scene_id in range(args.scenes):
            record = make_scene_record(scene_id, cfg, hand, pool, cut, seed=0)
            voxels.append(len(record["voxel_index"]))
            targets.append(int(record["voxel_rotation_mask"].sum()))
        coverage.append(
            {
                "grasps": n,
                "labelled_voxels_per_scene": round(float(np.mean(voxels)), 1),
                "rotation_targets_per_scene": round(float(np.mean(targets)), 1),
            }
        )
        print(gripper, coverage[-1])

    closure = float(np.mean([r["closure_seconds_per_closure"] for r in per_object]))
    ramp = float(np.mean([r["seconds_per_ramp_by_K"][32] for r in per_object]))
    ramp_fast = float(np.mean([r["seconds_per_ramp_fast"] for r in per_object]))
    yield_ = float(np.mean([r["yield"] for r in per_object]))

    def seconds(grasps: int, k: int, ramp_s: float = ramp) -> float:
        """Seconds per database predicted from the measured closure and ramp costs."""
        return round(grasps / yield_ * closure + grasps * k * ramp_s, 1)

    return {
        "gripper": gripper,
        "objects": per_object,
        "yield_mean": round(yield_, 3),
        "closure_seconds_mean": round(closure, 4),
        "ramp_seconds_mean": round(ramp, 5),
        "ramp_seconds_fast_mean": round(ramp_fast, 5),
        "predicted_seconds_per_database": {
            f"{g} grasps, K={k}": seconds(g, k) for g in (100, 200, 300) for k in (8, 16, 32)
        }
        | {f"{g} grasps, K=16, ramp {FAST_RAMP} s": seconds(g, 16, ramp_fast) for g in (100, 200)},
        "direction_errors": direction_errors(
            {K: np.concatenate(v) for K, v in scores.items()}, np.concatenate(fast)
        ),
        "coverage": coverage,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--objects", type=int, default=8, help="pool objects per gripper")
    parser.add_argument("--grasps", type=int, default=300, help="grasps of the coverage databases")
    parser.add_argument(
        "--direction-grasps", type=int, default=15, help="held grasps scored with every K"
    )
    parser.add_argument("--scenes", type=int, default=20, help="scenes per database size")
    parser.add_argument(
        "--out", default="experiments/results/grasp_db.json", help="result file (JSON)"
    )
    args = parse_args(
        parser,
        outputs=("out",),
        quick={"objects": 1, "grasps": 3, "direction_grasps": 1, "scenes": 1},
    )
    cells = [measure(gripper, args) for gripper in GRIPPERS]
    write_result(
        str(args.out).removesuffix(".json"),
        "grasp databases on VGN meshes",
        command_line(""),
        cells,
        objects=OBJECTS,
    )


if __name__ == "__main__":
    run_main(main)
