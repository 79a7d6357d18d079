"""Latency of grasp detection, depth image to ranked grasps → benchmarks/results/detect.json.

    PYTHONPATH=src python benchmarks/detect.py [--model bingham2d-robotiq-2f85] [--repeats 30]
        [--quick [DIR]]

Renders one 640×480 depth image of a 5-object household-test pile (seed 0) from the default
camera, then times ``GraspDetector.detect`` on it ``--repeats`` times after a warm-up, per
stage (TSDF fusion, network, decoding) as the detector reports them, plus the whole call.
Target: ≤ 25 ms per image (median) on the 2-core CPU. The decoding stage depends on how many
voxels pass the thresholds, so the shipped model is timed, not a random network.
``--quick`` times two calls.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from datetime import datetime, timezone
from pathlib import Path

from symgrasp.detect import GraspDetector
from symgrasp.perception import CameraIntrinsic, default_extrinsic
from symgrasp.scripts import machine, parse_args, run_main
from symgrasp.sim.objects import object_set
from symgrasp.sim.render import make_renderer
from symgrasp.sim.world import pile_scene

TARGET_MS = 25.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default="bingham2d-robotiq-2f85", help="model name or path")
    parser.add_argument("--repeats", type=int, default=30, help="timed calls (default: 30)")
    parser.add_argument("--out", default="benchmarks/results/detect.json", help="result file")
    args = parse_args(parser, outputs=("out",), quick={"repeats": 2})

    detector = GraspDetector.from_pretrained(args.model, device="cpu")
    world = pile_scene(object_set("household-test", 5, seed=0), seed=0, gripper=detector.gripper)
    intrinsic, T = CameraIntrinsic(), default_extrinsic()
    renderer = make_renderer(intrinsic)
    depth = renderer.render(world, T)

    detector.detect(depth, intrinsic, T)  # warm-up
    stages: dict[str, list[float]] = {"tsdf": [], "network": [], "decode": [], "total": []}
    for _ in range(args.repeats):
        start = time.perf_counter()
        grasps = detector.detect(depth, intrinsic, T)
        stages["total"].append(1e3 * (time.perf_counter() - start))
        for stage, ms in detector.timing.items():
            stages[stage].append(ms)

    result = {
        "benchmark": "GraspDetector.detect: one 640×480 depth image to a ranked grasp list",
        "command": "PYTHONPATH=src python benchmarks/detect.py "
        f"--model {args.model} --repeats {args.repeats}",
        "date": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "machine": machine(),
        "model": args.model,
        "depth_renderer": renderer.name,
        "grasps_returned": len(grasps),
        "statistic": f"median and best of {args.repeats} calls after a warm-up, milliseconds",
        "median_ms": {k: statistics.median(v) for k, v in stages.items()},
        "best_ms": {k: min(v) for k, v in stages.items()},
        "target_ms": TARGET_MS,
        "meets_target": statistics.median(stages["total"]) <= TARGET_MS,
    }
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(result, indent=1) + "\n")
    print(json.dumps({k: result[k] for k in ("median_ms", "best_ms", "grasps_returned")}, indent=1))


if __name__ == "__main__":
    run_main(main)
