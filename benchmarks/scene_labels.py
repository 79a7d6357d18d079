"""What a scene's labels cost in grasp databases: every score measured, or only those read
→ benchmarks/results/scene_labels.json.

    SYMGRASP_DATA=../shared PYTHONPATH=src python benchmarks/scene_labels.py [--scenes 2]
        [--grasps 150] [--directions 16] [--out ...] [--quick [DIR]]

A scene reads a database grasp's score only along the ≤ 3 directions nearest its gravity and
only if the grasp survives the scene's collision check. Cells: each gripper on the first
declutter state of the benchmark's rounds 0 … ``--scenes``−1 on ``vgn-pile-test`` (pile) and
``vgn-packed-test`` (packed), 5 objects (`symgrasp.objects.sets.make_scene`, what
`symgrasp bench declutter` plays), every object a new draw, so a new database, as in the oracle
planner's rounds (`symgrasp.peers.oracle`). Each scene's labels (`symgrasp.data.scenes.
scene_grasps` with the training databases' configuration) are made three ways, in an order
that alternates from scene to scene so that a change of the shared machine's load falls on all:

- **stepwise**: `build_database` for every object, its force ramps stepped one `World.step` at
  a time (`symgrasp.sim.execute.stepwise_pull_out_forces`): the code when issue 36 was filed;
- **whole**: `build_database` as it is (every score measured, `World.push_until_slip`);
- **on demand**: `OnDemandDatabase` (closures at once, a score measured when first read).

Reports seconds per scene and per held grasp of each, the ratios stepwise / on demand and
whole / on demand (totals; bootstrap 95 % interval over scenes), the share of (grasp,
direction) scores the scene read, and whether the three gave the same labels bit for bit
(poses, collisions, the surviving grasps' scores). One process, one core.
Needs VGN's object sets (``symgrasp objects fetch vgn``); stops with exit status 66 without them.

``--quick``: one scene per cell, 4 grasps, 4 directions.
"""

from __future__ import annotations

import argparse
import os
import time

import lab  # noqa: F401  (puts the checkout's root on sys.path, for experiments.scripts)
import numpy as np

from experiments.scripts import command_line, parse_args, run_main, write_result
from symgrasp.benchmark.runner import BOOTSTRAP
from symgrasp.config import TRAINING_DATABASE, DatabaseConfig, SceneConfig
from symgrasp.data import grasp_db
from symgrasp.data.grasp_db import OnDemandDatabase, build_database
from symgrasp.data.scenes import scene_grasps
from symgrasp.names import GRIPPERS
from symgrasp.objects.sets import make_scene, resolve
from symgrasp.sim.execute import stepwise_pull_out_forces
from symgrasp.sim.grippers import get_gripper

SETS = (("vgn-pile-test", "pile"), ("vgn-packed-test", "packed"))
VARIANTS = ("stepwise", "whole", "on_demand")
FAST_RAMPS = grasp_db.pull_out_forces


def _labels(world, hand, cfg: SceneConfig, variant: str) -> tuple[dict, float, int, int]:
    """The scene's `scene_grasps` made the ``variant`` way, its seconds, the (grasp, direction)
    scores measured and the held grasps."""
    grasp_db.pull_out_forces = stepwise_pull_out_forces if variant == "stepwise" else FAST_RAMPS
    try:
        start = time.perf_counter()
        if variant == "on_demand":
            dbs = [OnDemandDatabase(o, hand, cfg.database) for o in world.objects]
        else:
            dbs = [build_database(o, hand, cfg.database) for o in world.objects]
        grasps = scene_grasps(
            world.objects, world.object_poses(), dbs, cfg, hand, np.random.default_rng(0)
        )
        seconds = time.perf_counter() - start
    finally:
        grasp_db.pull_out_forces = FAST_RAMPS
    measured = sum(int(np.isfinite(db.score[db.held]).sum()) for db in dbs)
    return grasps, seconds, measured, sum(int(db.held.sum()) for db in dbs)


def _same(a: dict, b: dict) -> bool:
    kept = ~a["collides"]
    return (
        np.array_equal(a["T_world_tcp"], b["T_world_tcp"])
        and np.array_equal(a["collides"], b["collides"])
        and np.array_equal(a["score"][kept], b["score"][kept])
    )


def measure_scene(objects: str, scene: str, gripper: str, seed: int, cfg: SceneConfig) -> dict:
    hand = get_gripper(gripper)
    world = make_scene(scene, objects, 5, seed, gripper=hand)
    order = VARIANTS if seed % 2 == 0 else VARIANTS[::-1]
    made, seconds, measured = {}, {}, {}
    for variant in order:
        made[variant], seconds[variant], measured[variant], held = _labels(
            world, hand, cfg, variant
        )
    cell = {
        "objects": objects,
        "scene": scene,
        "gripper": gripper,
        "seed": seed,
        "held": held,
        "surviving": int((~made["whole"]["collides"]).sum()),
        "directions": cfg.database.directions,
        "scores_read": measured["on_demand"],
        "share_of_scores_read": round(
            measured["on_demand"] / max(held * cfg.database.directions, 1), 4
        ),
        **{f"seconds_{v}": round(seconds[v], 3) for v in VARIANTS},
        **{f"ms_per_grasp_{v}": round(1e3 * seconds[v] / max(held, 1), 2) for v in VARIANTS},
        "identical": _same(made["whole"], made["stepwise"])
        and _same(made["whole"], made["on_demand"]),
        "load_average_1min": round(os.getloadavg()[0], 2),
    }
    print(cell)
    return cell


def summary(cells: list[dict], rng: np.random.Generator) -> dict:
    """Seconds per scene and per held grasp of each variant over ``cells``, and the ratios of
    the totals to on demand's with bootstrap 95 % intervals over scenes."""
    held = np.array([c["held"] for c in cells])
    seconds = {v: np.array([c[f"seconds_{v}"] for c in cells]) for v in VARIANTS}
    picks = rng.integers(len(cells), size=(BOOTSTRAP, len(cells)))
    out: dict = {"scenes": len(cells)}
    for v in VARIANTS:
        out[f"seconds_per_scene_{v}"] = round(float(seconds[v].mean()), 2)
        out[f"ms_per_grasp_{v}"] = round(1e3 * seconds[v].sum() / held.sum(), 2)
    for v in ("stepwise", "whole"):
        ratios = seconds[v][picks].sum(axis=1) / seconds["on_demand"][picks].sum(axis=1)
        out[f"ratio_{v}_to_on_demand"] = round(seconds[v].sum() / seconds["on_demand"].sum(), 2)
        out[f"ratio_{v}_to_on_demand_interval_95"] = [
            round(float(q), 2) for q in np.quantile(ratios, [0.025, 0.975])
        ]
    read = sum(c["scores_read"] for c in cells)
    out["share_of_scores_read"] = round(read / (held.sum() * cells[0]["directions"]), 4)
    out["identical"] = all(c["identical"] for c in cells)
    return out


def table(result: dict) -> str:
    rows = [
        "| cells (scenes) | s per scene: stepwise | whole | on demand | ms per held grasp: "
        "stepwise / whole / on demand | stepwise ÷ on demand [95 %] | whole ÷ on demand [95 %] "
        "| scores read | labels equal |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for name, s in result.items():
        (a, b), (c, d) = (
            s["ratio_stepwise_to_on_demand_interval_95"],
            s["ratio_whole_to_on_demand_interval_95"],
        )
        rows.append(
            f"| {name} ({s['scenes']}) | {s['seconds_per_scene_stepwise']} "
            f"| {s['seconds_per_scene_whole']} | {s['seconds_per_scene_on_demand']} "
            f"| {s['ms_per_grasp_stepwise']} / {s['ms_per_grasp_whole']} / "
            f"{s['ms_per_grasp_on_demand']} | **{s['ratio_stepwise_to_on_demand']}** [{a}, {b}] "
            f"| {s['ratio_whole_to_on_demand']} [{c}, {d}] "
            f"| {100 * s['share_of_scores_read']:.1f} % | {s['identical']} |"
        )
    return "\n".join(rows) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--scenes", type=int, default=2, help="declutter rounds' first states per set and gripper"
    )
    parser.add_argument(
        "--grasps", type=int, default=TRAINING_DATABASE.grasps, help="held grasps per database"
    )
    parser.add_argument(
        "--directions", type=int, default=TRAINING_DATABASE.directions, help="ramp directions K"
    )
    parser.add_argument("--out", default="benchmarks/results/scene_labels.json", help="result file")
    args = parse_args(parser, outputs=("out",), quick={"scenes": 1, "grasps": 4, "directions": 4})
    for objects, _ in SETS:
        resolve(objects)  # first: no work without the data
    cfg = SceneConfig(database=DatabaseConfig(grasps=args.grasps, directions=args.directions))
    cells = [
        measure_scene(objects, scene, gripper, seed, cfg)
        for gripper in GRIPPERS
        for objects, scene in SETS
        for seed in range(args.scenes)
    ]
    rng = np.random.default_rng(0)
    summaries = {
        **{g: summary([c for c in cells if c["gripper"] == g], rng) for g in GRIPPERS},
        "all": summary(cells, rng),
    }
    print(table(summaries))
    write_result(
        str(args.out).removesuffix(".json"),
        "a scene's labels in grasp databases: every score measured, or only those read",
        command_line(""),
        cells,
        table(summaries),
        summary=summaries,
    )


if __name__ == "__main__":
    run_main(main)
