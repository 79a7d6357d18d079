"""Latency of grasp detection, depth image to ranked grasps → benchmarks/results/detect.json.

    PYTHONPATH=src python benchmarks/detect.py [--model bingham2d-robotiq-2f85] [--repeats 100]
        [--block 10] [--device cpu] [--table-scale] [--approach-check] [--fallbacks N]
        [--quick [DIR]]

Renders one 640×480 depth image of a 5-object household-test pile (seed 0) from the default
camera, then times ``GraspDetector.detect`` on it, per stage (TSDF fusion, network, decoding, cut)
as the detector reports them, plus the whole call, for two detectors of the same model: the
network run eagerly (the default) and as a TorchScript graph made for inference
(``optimize=True``). The two alternate in blocks of ``--block`` calls, so that a change of the
machine's load falls on both, for ``--repeats`` calls each after a warm-up. Both must return
the same grasps. Target: ≤ 15 ms per image (median) on the 2-core CPU, for the optimised
detector. ``--device cuda`` times both on a GPU instead (written to ``detect-cuda.json``; the
target is the CPU's). ``--table-scale`` times detectors that divide the image by the depth
scale read off the table first (``GraspDetector(table_scale=True)``, part of the TSDF stage;
written to ``detect-table.json``, or ``detect-DEVICE-table.json``). ``--approach-check`` times
detectors that return only the grasps whose approach keeps the benchmark's clearances
(``GraspDetector(approach_check=True)``: a stage of its own, ``approach``, after decoding;
written with ``-approach`` in the name). ``--fallbacks N`` times detectors that follow each
voxel's grasp with N other rotations of it (``GraspDetector(fallbacks=N)``: drawn in the
decoding stage, or with ``--approach-check`` in the approach stage and only when a voxel's own
grasp was refused; written with ``-fallbacksN`` in the name). A shipped model decodes at its
model card's operating point, recorded as ``decoding``. The decoding stage depends
on how many voxels pass the thresholds, so the shipped model is timed, not a random network. ``--quick`` times two calls of each.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from datetime import datetime, timezone
from pathlib import Path

import lab  # noqa: F401  (puts the checkout's root on sys.path, for experiments.scripts)
import numpy as np

from experiments.scripts import command_line, machine, output_path, parse_args, run_main
from symgrasp.detect import GraspDetector
from symgrasp.detect.pretrained import OPERATING_POINT_KEYS
from symgrasp.perception import CameraIntrinsic, default_extrinsic
from symgrasp.sim.objects import object_set
from symgrasp.sim.render import make_renderer
from symgrasp.sim.world import pile_scene

TARGET_MS = 15.0
DEFAULT_OUT = "benchmarks/results/detect.json"
STAGES = ("tsdf", "network", "decode", "cut", "width", "total")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default="bingham2d-robotiq-2f85", help="model name or path")
    parser.add_argument(
        "--repeats", type=int, default=100, help="timed calls of each detector (default: 100)"
    )
    parser.add_argument(
        "--block", type=int, default=10, help="calls in a row before switching (default: 10)"
    )
    parser.add_argument(
        "--device", default="cpu", help="where TSDF and network run: cpu or cuda (default: cpu)"
    )
    parser.add_argument(
        "--table-scale",
        action="store_true",
        help="detectors that read the image's depth scale off the table first "
        "(GraspDetector(table_scale=True); default: off)",
    )
    parser.add_argument(
        "--out",
        default=None,
        help=f"result file (default: {DEFAULT_OUT}, with -DEVICE off the CPU, -table, -approach "
        "and -fallbacksN in its name for those options)",
    )
    parser.add_argument(
        "--approach-check",
        action="store_true",
        help="detectors that keep only the grasps whose approach is free of the seen surface "
        "and the table (GraspDetector(approach_check=True), timed as its own stage; default: "
        "off)",
    )
    parser.add_argument(
        "--fallbacks",
        type=int,
        default=None,
        metavar="N",
        help="detectors that follow each voxel's grasp with N other rotations of it "
        "(GraspDetector(fallbacks=N); default: the model card's, else none)",
    )
    args = parse_args(parser, outputs=("out",), quick={"repeats": 2, "block": 1})
    on_cpu = args.device == "cpu"
    if args.out is None:  # the published name says what the options change
        suffix = ("" if on_cpu else f"-{args.device}") + ("-table" if args.table_scale else "")
        suffix += "-approach" if args.approach_check else ""
        suffix += "" if args.fallbacks is None else f"-fallbacks{args.fallbacks}"
        args.out = output_path(Path(DEFAULT_OUT).with_name(f"detect{suffix}.json"), args)
    out = Path(args.out)

    options = {"device": args.device, "table_scale": args.table_scale,
               "approach_check": args.approach_check}  # fmt: skip
    if args.fallbacks is not None:
        options["fallbacks"] = args.fallbacks
    stages = STAGES + ("approach",) * args.approach_check
    detectors = {
        "eager": GraspDetector.from_pretrained(args.model, **options),
        "optimized": GraspDetector.from_pretrained(args.model, optimize=True, **options),
    }
    world = pile_scene(
        object_set("household-test", 5, seed=0), seed=0, gripper=detectors["eager"].gripper
    )
    intrinsic, T = CameraIntrinsic(), default_extrinsic()
    renderer = make_renderer(intrinsic)
    depth = renderer.render(world, T)

    grasps = {path: detector.detect(depth, intrinsic, T) for path, detector in detectors.items()}
    same = _same_grasps(*grasps.values())
    times = {path: {stage: [] for stage in stages} for path in detectors}
    for _ in range(0, args.repeats, args.block):
        for path, detector in detectors.items():
            for _ in range(args.block):
                begin = time.perf_counter()
                detector.detect(depth, intrinsic, T)
                times[path]["total"].append(1e3 * (time.perf_counter() - begin))
                for stage, ms in detector.timing.items():
                    times[path][stage].append(ms)

    median = {p: {s: statistics.median(v) for s, v in t.items()} for p, t in times.items()}
    result = {
        "benchmark": "GraspDetector.detect: one 640×480 depth image to a ranked grasp list, "
        "the network eager and optimized (TorchScript, made for inference)",
        "command": command_line(""),
        "date": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "machine": machine(),
        "device": str(detectors["eager"].device),
        "model": args.model,
        "table_scale": args.table_scale,
        "approach_check": args.approach_check,
        "decoding": {key: getattr(detectors["eager"], key) for key in OPERATING_POINT_KEYS},
        "depth_renderer": renderer.name,
        "grasps_returned": len(grasps["eager"]),
        "same_grasps": same,
        "statistic": f"median and best of {args.repeats} calls of each after a warm-up, "
        f"alternating in blocks of {args.block}, milliseconds",
        "median_ms": median,
        "best_ms": {p: {s: min(v) for s, v in t.items()} for p, t in times.items()},
        "target_ms": TARGET_MS if on_cpu else None,
        "meets_target": median["optimized"]["total"] <= TARGET_MS if on_cpu else None,
    }
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(result, indent=1) + "\n")
    print(
        json.dumps({k: result[k] for k in ("median_ms", "same_grasps", "meets_target")}, indent=1)
    )


def _same_grasps(a: list, b: list) -> dict:
    """Whether two detectors' grasp lists pick the same voxels in the same order, and how far
    apart their poses and scores are (None where the voxels differ)."""
    same = [g.voxel for g in a] == [g.voxel for g in b]
    pairs = list(zip(a, b, strict=True)) if same else []
    pose = max((float(np.abs(x.pose - y.pose).max()) for x, y in pairs), default=0.0)
    score = max((abs(x.score - y.score) for x, y in pairs), default=0.0)
    return {
        "voxels_in_order": same,
        "max_pose_difference": pose if same else None,
        "max_score_difference": score if same else None,
    }


if __name__ == "__main__":
    run_main(main)
