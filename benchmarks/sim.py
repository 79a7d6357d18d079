"""Wall-clock cost of the simulation world's real code paths → benchmarks/results/sim.json.

    PYTHONPATH=src python benchmarks/sim.py [--repeats 20] [--out benchmarks/results/sim.json]
        [--quick [DIR]]

Times one grasp trial per gripper (a top grasp on a settled box, object removal included),
a 5-object pile (generation, settling with the walls, their removal, settling again), a
pile of 5 of VGN's test meshes as the declutter benchmark builds one (with the data folder), one
640×480 depth render (OpenGL where it works, of an unchanged world and the first after a
rebuild of its model, and the ray-cast fallback) and one TSDF fusion of that image into the
40³ grid. Reports medians over ``--repeats`` runs after one warm-up.
``--quick`` times every case twice after its warm-up.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time
from collections.abc import Callable
from datetime import datetime, timezone
from pathlib import Path

import lab  # noqa: F401  (puts the checkout's root on sys.path, for experiments.scripts)
import numpy as np

from experiments.scripts import command_line, machine, parse_args, run_main
from symgrasp.objects.folder import MissingData
from symgrasp.objects.sets import make_scene, resolve
from symgrasp.perception import CameraIntrinsic, TSDFVolume, default_extrinsic
from symgrasp.sim import World, execute_grasp, get_gripper
from symgrasp.sim.execute import top_grasp
from symgrasp.sim.objects import ObjectSpec, Part
from symgrasp.sim.render import GLRenderer, RaycastRenderer, gl_available
from symgrasp.workspace import TABLE_HEIGHT

TARGETS_MS = {"grasp_trial": 50.0, "pile_5_objects": 200.0, "render_plus_tsdf_gl": 30.0}


def _time(run: Callable[[int], object], repeats: int, setup: Callable[[int], object] | None = None):
    """Median and all wall times [ms] of ``run(setup(i))`` (setup untimed), after a warm-up."""
    times = []
    for i in range(repeats + 1):  # run 0 warms up
        arg = setup(i) if setup else i
        start = time.perf_counter()
        run(arg)
        if i > 0:
            times.append(1e3 * (time.perf_counter() - start))
    return {"median_ms": statistics.median(times), "min_ms": min(times), "runs": len(times)}


def _box_world(name: str) -> tuple[World, np.ndarray]:
    gripper = get_gripper(name)
    box = ObjectSpec("box", "box", (Part("box", (0.025, 0.025, 0.03), (0, 0, 0.03)),), 0.2, 0.8)
    world = World([box], gripper=gripper)
    world.settle(0.5)
    z = TABLE_HEIGHT + 0.06 + 0.015 - gripper.tip_beyond_tcp
    return world, top_grasp(np.array([0.15, 0.15, z]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=20, help="timed runs per case")
    parser.add_argument("--out", default="benchmarks/results/sim.json", help="JSON output path")
    args = parse_args(parser, outputs=("out",), quick={"repeats": 2})
    results: dict[str, object] = {}
    for gripper in ("franka", "robotiq-2f85"):
        outcomes = []

        def trial(world_pose, outcomes=outcomes):
            outcomes.append(execute_grasp(world_pose[0], world_pose[1]).outcome.value)

        timing = _time(trial, args.repeats, setup=lambda _, g=gripper: _box_world(g))
        timing["outcomes"] = sorted(set(outcomes))
        results[f"grasp_trial_{gripper}"] = timing

    kept = []
    results["pile_5_objects"] = _time(
        lambda seed: kept.append(len(make_scene("pile", "household-train", 5, seed).objects)),
        args.repeats,
    )
    results["pile_5_objects"]["objects_kept_mean"] = float(np.mean(kept))
    try:
        vgn = resolve("vgn-pile-test")
    except MissingData as error:
        print(f"vgn_pile_5_objects skipped: {error}")
    else:
        for k in range(len(vgn.files)):  # a long benchmark's worker has read them all
            vgn.load(k)
        results["vgn_pile_5_objects"] = _time(
            lambda seed: make_scene("pile", vgn, 5, seed), args.repeats
        )

    intrinsic = CameraIntrinsic()
    T = default_extrinsic()
    world = make_scene("pile", "household-train", 5, seed=0)
    ray = RaycastRenderer(intrinsic)
    results["render_raycast"] = _time(lambda _: ray.render(world, T), args.repeats)
    depth = ray.render(world, T)
    results["tsdf_fusion"] = _time(
        lambda _: TSDFVolume().integrate(depth, intrinsic, T), args.repeats
    )
    if gl_available():
        gl = GLRenderer(intrinsic)
        results["render_gl"] = _time(lambda _: gl.render(world, T), args.repeats)
        results["render_plus_tsdf_gl"] = _time(
            lambda _: TSDFVolume().integrate(gl.render(world, T), intrinsic, T), args.repeats
        )
        # the benchmark's and the data's usual case: the first image of a rebuilt model (an
        # object removed, a new scene), which makes the renderer's GL context anew
        results["render_gl_rebuilt_world"] = _time(
            lambda _: gl.render(world, T), args.repeats, setup=lambda _: world.rebuild()
        )
    results["render_plus_tsdf_raycast"] = _time(
        lambda _: TSDFVolume().integrate(ray.render(world, T), intrinsic, T), args.repeats
    )

    targets = {
        "grasp_trial_franka": TARGETS_MS["grasp_trial"],
        "grasp_trial_robotiq-2f85": TARGETS_MS["grasp_trial"],
        "pile_5_objects": TARGETS_MS["pile_5_objects"],
        "render_plus_tsdf_gl": TARGETS_MS["render_plus_tsdf_gl"],
    }
    for name, target in targets.items():
        if name in results:
            results[name]["target_ms"] = target
            results[name]["meets_target"] = results[name]["median_ms"] <= target

    pythonpath = os.environ.get("PYTHONPATH")
    report = {
        "command": command_line(f"PYTHONPATH={pythonpath}" if pythonpath else ""),
        "date": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "machine": {
            **machine(),
            "mujoco_gl": os.environ.get("MUJOCO_GL", ""),
            "gl_available": gl_available(),
        },
        "results": results,
    }
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(report, indent=2) + "\n")
    for name, r in results.items():
        flag = "" if "meets_target" not in r else (" ok" if r["meets_target"] else " SLOW")
        print(f"{name:28s} {r['median_ms']:8.1f} ms{flag}")


if __name__ == "__main__":
    run_main(main)
