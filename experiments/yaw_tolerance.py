"""How many yaws a good grasp tolerates → experiments/results/yaw_tolerance.{json,md}.

    PYTHONPATH=src python experiments/yaw_tolerance.py [--rounds 200] [--quick [DIR]]

A regressor trained towards both rotations of a symmetric grasp outputs an averaged yaw; what
that costs depends on how many yaws would have worked. For the first grasp of each declutter
round (`symgrasp.benchmark.declutter`: seeds 0…, the shipped ``bingham2d`` model of the
gripper, the first candidate whose approach is free), this replays the trial from the same
state turned about its approach axis by 0°, 30°, …, 150° (`failures.turned_about_approach`)
and reports, of the grasps that succeed unturned, the share of the five turns that also
succeed: the yaw tolerance, with a 95 % bootstrap interval over grasps. Per object family
too (`failures.aimed_object`). ``--quick`` plays one round per cell.
"""

from __future__ import annotations

import argparse
from collections import defaultdict
from typing import Any

import numpy as np
from common import GRIPPERS, add_result_option
from scripts import command_line, parse_args, run_main, write_result
from tqdm import tqdm

from symgrasp.benchmark.declutter import first_free
from symgrasp.benchmark.failures import YAW_OFFSETS, aimed_object, turned_about_approach
from symgrasp.benchmark.runner import BOOTSTRAP
from symgrasp.detect import GraspDetector
from symgrasp.perception import CameraIntrinsic, default_extrinsic
from symgrasp.sim.execute import execute_grasp
from symgrasp.sim.objects import object_set
from symgrasp.sim.render import make_renderer
from symgrasp.sim.world import pile_scene

OBJECTS = ("household-test", "large-box")


def first_grasp_at_every_yaw(
    detector: GraspDetector, objects: str, seed: int
) -> tuple[str, list[bool]] | None:
    """The family aimed at by the first free grasp of round ``seed`` and whether it succeeds
    turned by 0 and by each of `YAW_OFFSETS`; None when the detector finds no free grasp."""
    intrinsic, T_world_camera = CameraIntrinsic(), default_extrinsic()
    world = pile_scene(object_set(objects, 5, seed), seed=seed, gripper=detector.gripper)
    depth = make_renderer(intrinsic).render(world, T_world_camera)
    volume = detector.fuse(depth, intrinsic, T_world_camera)
    candidates = detector.detect_tsdf(volume.grid())
    chosen, _ = first_free(candidates, detector.gripper, volume.point_cloud().cpu().numpy())
    if chosen is None:
        return None
    family = world.objects[aimed_object(world, chosen.pose)].family
    start = world.snapshot()
    held = []
    for angle in (0.0, *YAW_OFFSETS):
        world.restore(start)
        turned = turned_about_approach(chosen.pose, float(angle))
        held.append(execute_grasp(world, turned, remove=False).success)
    return family, held


def tolerance(trials: list[list[bool]], seed: int = 0) -> dict[str, Any]:
    """Grasps, those that succeed unturned, and the mean share of turns that then succeed
    with its 95 % bootstrap interval over those grasps."""
    shares = np.array([np.mean(t[1:]) for t in trials if t[0]])
    interval = [float("nan")] * 2
    if len(shares):
        picks = np.random.default_rng(seed).integers(len(shares), size=(BOOTSTRAP, len(shares)))
        interval = np.percentile(shares[picks].mean(1), [2.5, 97.5]).tolist()
    return {
        "grasps": len(trials),
        "succeed_unturned": len(shares),
        "turns_that_succeed": float(shares.mean()) if len(shares) else float("nan"),
        "turns_that_succeed_ci95": interval,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=200, help="rounds (seeds 0…) per cell")
    add_result_option(parser, "yaw_tolerance")
    args = parse_args(parser, outputs=("result",), quick={"rounds": 1})

    cells = []
    for gripper in GRIPPERS:
        detector = GraspDetector.from_pretrained(f"bingham2d-{gripper}", device="cpu")
        for objects in OBJECTS:
            by_family: dict[str, list[list[bool]]] = defaultdict(list)
            for seed in tqdm(range(args.rounds), desc=f"{gripper} {objects}", unit="round"):
                trial = first_grasp_at_every_yaw(detector, objects, seed)
                if trial is not None:
                    by_family[trial[0]].append(trial[1])
            trials = [t for family in by_family.values() for t in family]
            cells.append({
                "gripper": gripper, "objects": objects, **tolerance(trials),
                "families": {f: tolerance(by_family[f]) for f in sorted(by_family)},
            })  # fmt: skip

    text = ["| gripper | objects | first grasps | succeed unturned | turns (30°…150°) that also succeed |",
            "|---|---|---|---|---|"]  # fmt: skip
    for c in cells:
        lo, hi = c["turns_that_succeed_ci95"]
        text.append(f"| {c['gripper']} | {c['objects']} | {c['grasps']} | {c['succeed_unturned']} "
                    f"| {c['turns_that_succeed']:.0%} [{lo:.0%}, {hi:.0%}] |")  # fmt: skip
    families = sorted({f for c in cells if c["objects"] == "household-test" for f in c["families"]})
    text += ["", "Household-test, per family (turns that also succeed [grasps that succeed unturned]):",
             "", "| family | " + " | ".join(GRIPPERS) + " |", "|---|" + "---|" * len(GRIPPERS)]  # fmt: skip
    for family in families:
        entries = []
        for gripper in GRIPPERS:
            c = next(
                c for c in cells if c["gripper"] == gripper and c["objects"] == "household-test"
            )
            t = c["families"].get(
                family, {"succeed_unturned": 0, "turns_that_succeed": float("nan")}
            )
            entries.append(f"{t['turns_that_succeed']:.0%} [{t['succeed_unturned']}]"
                           if t["succeed_unturned"] else "–")  # fmt: skip
        text.append(f"| {family} | " + " | ".join(entries) + " |")
    table = "\n".join(text) + "\n"
    print(table)
    write_result(
        args.result,
        "yaw tolerance of the first grasp of each declutter round",
        command_line("PYTHONPATH=src"),
        cells,
        table,
        rounds=args.rounds,
        yaw_offsets_deg=np.rad2deg(YAW_OFFSETS).tolist(),
    )


if __name__ == "__main__":
    run_main(main)
