"""Depth as real sensors give it, against the rendered image it stands for →
experiments/results/sensor_depth.{json,md}.

    PYTHONPATH=src python experiments/sensor_depth.py [--scenes 50] [--model NAME]
        [--quick [DIR]]

On ``--scenes`` 5-object household-train piles (scene seed = pile seed = 0, 1, …), each seen
from a random camera of training's range (`symgrasp.data.scenes.random_camera`, default
`SceneConfig`) in 640 × 480, the shipped detector's grasps on the rendered depth are the
reference; each variant below changes the image as a sensor would, and is judged by how many
of the reference grasps it finds again (recall) and how many of its grasps are reference ones
(precision), a grasp matching one within 1 voxel (Chebyshev) whose approach is within 25°;
and by the TSDF voxels that moved by more than half the truncation. Rates are pooled over the
scenes with a 95% bootstrap interval over scenes.

Variants: the image written as a 16-bit PNG in millimetres and in tenths of a millimetre and
read back (`symgrasp.detect.files`); 5% of the pixels dropped at random (invalid zeros), fused
as they are and with ``fill_holes`` 1; the pixels within 2 px of a depth jump over 2 cm
dropped (the edge holes of a stereo or structured-light sensor,
`symgrasp.perception.points.edge_holes`), fused as they are and with ``fill_holes`` 2 and 4.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np
import torch
from common import add_result_option
from scripts import command_line, parse_args, run_main, write_result

from symgrasp.benchmark.runner import BOOTSTRAP, pooled_ratio
from symgrasp.config import SceneConfig
from symgrasp.data.scenes import random_camera
from symgrasp.detect import GraspDetector
from symgrasp.detect.files import load_depth, save_png_depth
from symgrasp.perception import CameraIntrinsic
from symgrasp.perception.points import edge_holes
from symgrasp.sim.objects import object_set
from symgrasp.sim.render import make_renderer
from symgrasp.sim.world import pile_scene

MATCH_VOXELS = 1
MATCH_DEGREES = 25.0
DROPPED = 0.05
"""Share of pixels the dropout variant zeroes."""


def png_round_trip(depth: np.ndarray, scale: float, folder: Path) -> np.ndarray:
    return load_depth(save_png_depth(folder / "depth.png", depth, png_scale=scale), scale)


def matched(grasps: list, others: list) -> int:
    """How many of ``grasps`` match one of ``others``."""
    cos = np.cos(np.radians(MATCH_DEGREES))
    return sum(
        any(
            max(abs(np.subtract(g.voxel, o.voxel))) <= MATCH_VOXELS
            and g.approach @ o.approach >= cos
            for o in others
        )
        for g in grasps
    )


def pooled(hits: np.ndarray, totals: np.ndarray, seed: int = 0) -> tuple[float, float, float]:
    """The pooled ratio sum(hits)/sum(totals) over scenes (`pooled_ratio`: NaN when nothing
    was counted) and its 95% bootstrap interval."""
    rng = np.random.default_rng(seed)
    index = rng.integers(len(hits), size=(BOOTSTRAP, len(hits)))
    low, high = np.nanpercentile(pooled_ratio(hits[index], totals[index]), [2.5, 97.5])
    return float(pooled_ratio(hits, totals)), float(low), float(high)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", type=int, default=50, help="piles (default: 50)")
    parser.add_argument("--model", default="bingham2d-robotiq-2f85", help="model name or path")
    add_result_option(parser, "sensor_depth")
    args = parse_args(parser, outputs=("result",), quick={"scenes": 2})
    torch.set_num_threads(1)

    detector = GraspDetector.from_pretrained(args.model, device="cpu")
    filling = {n: GraspDetector(detector.model, detector.gripper, fill_holes=n, device="cpu")
               for n in (1, 2, 4)}  # fmt: skip
    intrinsic = CameraIntrinsic()
    renderer = make_renderer(intrinsic)
    variants = ["png, mm", "png, 0.1 mm", "5% dropped", "5% dropped, fill 1", "edge holes",
                "edge holes, fill 2", "edge holes, fill 4"]  # fmt: skip
    counts = {
        v: {"found": [], "reference": [], "kept": [], "given": [], "off": []} for v in variants
    }
    cfg = SceneConfig()
    with tempfile.TemporaryDirectory() as folder:
        for seed in range(args.scenes):
            world = pile_scene(object_set("household-train", 5, seed=seed), seed=seed,
                               gripper=detector.gripper)  # fmt: skip
            T = random_camera(cfg, np.random.default_rng(seed))
            depth = renderer.render(world, T)
            reference = detector.detect(depth, intrinsic, T)
            whole = detector.fuse(depth, intrinsic, T).grid()
            dropped = np.where(
                np.random.default_rng(seed).random(depth.shape) < DROPPED, 0.0, depth
            )
            holed = edge_holes(depth)
            inputs = {
                "png, mm": (detector, png_round_trip(depth, 0.001, Path(folder))),
                "png, 0.1 mm": (detector, png_round_trip(depth, 0.0001, Path(folder))),
                "5% dropped": (detector, dropped.astype(np.float32)),
                "5% dropped, fill 1": (filling[1], dropped.astype(np.float32)),
                "edge holes": (detector, holed),
                "edge holes, fill 2": (filling[2], holed),
                "edge holes, fill 4": (filling[4], holed),
            }
            for name, (used, image) in inputs.items():
                grasps = used.detect(image, intrinsic, T)
                off = int(((used.fuse(image, intrinsic, T).grid() - whole).abs() > 0.5).sum())
                count = counts[name]
                count["found"].append(matched(reference, grasps))
                count["reference"].append(len(reference))
                count["kept"].append(matched(grasps, reference))
                count["given"].append(len(grasps))
                count["off"].append(off)

    cells, rows = [], []
    for name in variants:
        c = {k: np.array(v) for k, v in counts[name].items()}
        recall = pooled(c["found"], c["reference"])
        precision = pooled(c["kept"], c["given"])
        cells.append({"variant": name, "recall": recall, "precision": precision,
                      "tsdf_voxels_off_mean": float(c["off"].mean()),
                      "grasps": int(c["given"].sum()), "reference_grasps": int(c["reference"].sum()),
                      **{k: v.tolist() for k, v in c.items()}})  # fmt: skip
        rows.append(
            f"| {name} | {recall[0]:.0%} [{recall[1]:.0%}, {recall[2]:.0%}] | "
            f"{precision[0]:.0%} [{precision[1]:.0%}, {precision[2]:.0%}] | "
            f"{c['off'].mean():.0f} |"
        )
    table = (
        f"{args.scenes} household-train piles, {int(cells[0]['reference_grasps'])} reference "
        "grasps\n\n| variant | recall [95% CI] | precision [95% CI] | TSDF voxels off |\n"
        "|---|---|---|---|\n" + "\n".join(rows) + "\n"
    )
    print(table, end="")
    write_result(
        args.result,
        "grasps on depth as real sensors give it, against the rendered image",
        command_line("PYTHONPATH=src"),
        cells,
        table,
        match=f"within {MATCH_VOXELS} voxel (Chebyshev) and {MATCH_DEGREES:g}° of approach",
        tsdf_voxels_off="voxels of 64 000 whose value moved by more than 0.5 (half the "
        "truncation) against the rendered image's TSDF, mean over scenes",
    )


if __name__ == "__main__":
    run_main(main)
