"""Where VGN's grasps belong on symgrasp's hands → experiments/results/vgn_frame.{json,md}.

    SYMGRASP_DATA=DIR PYTHONPATH=src python experiments/vgn_frame.py [--scenes 100] [--quick [DIR]]

The evidence for the frame mapping of `symgrasp.peers.vgn.to_symgrasp`. VGN's network (its
public weights, VGN's input and decoding) looks at one object of VGN's *training* meshes
(``vgn-pile-train``, dropped as a one-object pile, seeds 0…) from symgrasp's default camera;
its best grasp is executed by each built-in hand from the same state, placed in several ways:

- the TCP moved along the approach by 0, 10, …, 60 mm from VGN's TCP and by the mapping's
  own shift (`FINGER_REACH` − the hand's ``tip_beyond_tcp``: the fingertips where VGN's
  Panda hand would put them; 41.3 mm for the Franka hand, 32.8 mm for the Robotiq 2F-85);
- with the mapping's shift, the closing axis along VGN's x instead of its y (turned 90°);
- with the mapping's shift, the TCP at the voxel's centre instead of VGN's voxel corner
  (3.75 mm further along each world axis).

If the mapping is right, its shift succeeds about as often as the best of the sweep, the
turned closing axis fails most, and the voxel centre changes little. Success ratios with 95 %
bootstrap intervals over scenes; the alternatives' paired change against the mapping.
"""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np
from common import GRIPPERS, add_result_option
from scripts import command_line, parse_args, run_main, write_result
from tqdm import tqdm

from symgrasp.benchmark.failures import turned_about_approach
from symgrasp.benchmark.runner import BOOTSTRAP
from symgrasp.objects.sets import make_scene, resolve
from symgrasp.peers.vgn import FINGER_REACH, VGN
from symgrasp.perception import CameraIntrinsic, default_extrinsic
from symgrasp.sim.execute import execute_grasp
from symgrasp.sim.grippers import get_gripper
from symgrasp.sim.render import make_renderer
from symgrasp.workspace import VOXEL_SIZE

OBJECTS = "vgn-pile-train"
SHIFTS_MM = (0, 10, 20, 30, 40, 50, 60)
"""TCP shifts along the approach from VGN's TCP that the sweep tries [mm]."""
MAPPED = "mapping"


def placements(mapped: np.ndarray, gripper) -> dict[str, np.ndarray]:
    """``T_world_tcp`` of one VGN grasp for ``gripper`` by placement (module docstring), from
    its pose as the mapping places it (``mapped``, what `VGN.plan` returns)."""
    mapped_shift = FINGER_REACH - gripper.tip_beyond_tcp
    poses = {MAPPED: mapped}
    for mm in SHIFTS_MM:
        pose = mapped.copy()
        pose[:3, 3] += (mm / 1000 - mapped_shift) * mapped[:3, 0]
        poses[f"shift {mm} mm"] = pose
    poses["closing along VGN's x"] = turned_about_approach(mapped, np.pi / 2)
    centre = mapped.copy()
    centre[:3, 3] += VOXEL_SIZE / 2
    poses["voxel centre"] = centre
    return poses


def trial(vgn: VGN, source, seed: int) -> dict[str, str] | None:
    """The outcome of VGN's best grasp on scene ``seed`` by placement; None when VGN finds
    no grasp."""
    intrinsic, T_world_camera = CameraIntrinsic(), default_extrinsic()
    world = make_scene("pile", source, 1, seed, gripper=vgn.gripper)
    if not world.objects:
        return None
    depth = make_renderer(intrinsic).render(world, T_world_camera)
    grasps = vgn.detect(depth, intrinsic, T_world_camera)
    if not grasps:
        return None
    start = world.snapshot()
    outcomes = {}
    for name, pose in placements(grasps[0].pose, vgn.gripper).items():
        world.restore(start)
        outcomes[name] = execute_grasp(world, pose, remove=False).outcome.value
    return outcomes


def ratio(successes: np.ndarray, seed: int = 0) -> tuple[float, list[float]]:
    """The mean of ``successes`` (scenes,) and its 95 % bootstrap interval over scenes."""
    picks = np.random.default_rng(seed).integers(len(successes), size=(BOOTSTRAP, len(successes)))
    return float(successes.mean()), np.percentile(successes[picks].mean(1), [2.5, 97.5]).tolist()


def summary(trials: list[dict[str, str]]) -> dict[str, Any]:
    """Per placement: success ratio, its interval, the paired change against the mapping and
    the outcomes."""
    names = list(trials[0])
    success = {n: np.array([t[n] == "success" for t in trials], dtype=float) for n in names}
    cells = {}
    for name in names:
        value, interval = ratio(success[name])
        change, change_interval = ratio(success[name] - success[MAPPED])
        outcomes: dict[str, int] = {}
        for t in trials:
            outcomes[t[name]] = outcomes.get(t[name], 0) + 1
        cells[name] = {
            "success": value, "success_ci95": interval, "change": change,
            "change_ci95": change_interval, "outcomes": dict(sorted(outcomes.items())),
        }  # fmt: skip
    return cells


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", type=int, default=100,
                        help="one-object scenes (seeds 0…) per hand (default: %(default)s)")  # fmt: skip
    add_result_option(parser, "vgn_frame")
    args = parse_args(parser, outputs=("result",), quick={"scenes": 2})

    source = resolve(OBJECTS)
    cells = []
    for gripper in GRIPPERS:
        vgn = VGN(get_gripper(gripper))
        trials = []
        for seed in tqdm(range(args.scenes), desc=gripper, unit="scene"):
            outcome = trial(vgn, source, seed)
            if outcome is not None:
                trials.append(outcome)
        shift = 1000 * (FINGER_REACH - vgn.gripper.tip_beyond_tcp)
        cells.append({"gripper": gripper, "mapping_shift_mm": shift, "scenes": args.scenes,
                      "grasped_at": len(trials), "placements": summary(trials)})  # fmt: skip

    text = []
    for c in cells:
        text += [f"**{c['gripper']}** (the mapping moves the TCP {c['mapping_shift_mm']:.1f} mm "
                 f"along the approach; {c['grasped_at']} of {c['scenes']} scenes with a grasp):",
                 "", "| placement | success % [95 % CI] | change vs the mapping [95 % CI] | outcomes |",
                 "|---|---|---|---|"]  # fmt: skip
        for name, p in c["placements"].items():
            lo, hi = p["success_ci95"]
            clo, chi = p["change_ci95"]
            change = (
                "–"
                if name == MAPPED
                else f"{100 * p['change']:+.1f} [{100 * clo:+.1f}, {100 * chi:+.1f}]"
            )
            outcomes = ", ".join(f"{k} {v}" for k, v in p["outcomes"].items())
            text.append(f"| {name} | {100 * p['success']:.1f} [{100 * lo:.1f}, {100 * hi:.1f}] "
                        f"| {change} | {outcomes} |")  # fmt: skip
        text.append("")
    table = "\n".join(text)
    print(table)
    write_result(
        args.result,
        "VGN's best grasp on one training object, executed by each hand at several placements",
        command_line("SYMGRASP_DATA=../shared PYTHONPATH=src"),
        cells,
        table,
        objects=OBJECTS,
        scenes=args.scenes,
        finger_reach_m=FINGER_REACH,
    )


if __name__ == "__main__":
    run_main(main)
