"""What the grasp server adds to a detection's latency → benchmarks/results/serve.{json,md}.

    OMP_NUM_THREADS=1 PYTHONPATH=src python benchmarks/serve.py [--model bingham2d-robotiq-2f85]
        [--requests 50] [--threads 1] [--quick [DIR]]

Renders one 640×480 depth image of a 5-object household-test pile (seed 0) from the default
camera, as benchmarks/detect.py does, starts ``symgrasp serve`` in its own process on a free
loopback port, and times, paired on each of ``--requests`` rounds and in an order that turns
round every round, the same detection in this process (`GraspDetector.detect`) and through the
server (`symgrasp.serve.client.GraspClient`): the depth image as base64 and as nested lists,
and its point cloud (each seen pixel's point, base64) against `detect_points` here. The added
latency is the round trip minus the in-process call of the same round; its median over the
rounds has a bootstrap 95% interval. ``--quick`` plays 3 rounds. ``OMP_NUM_THREADS`` (the
BLAS and OpenMP threads, recorded) goes to the server too: on a shared 2-core machine two BLAS
threads made the point-cloud path here several times slower than in the server.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time

import lab  # noqa: F401  (puts the checkout's root on sys.path, for experiments.scripts)
import numpy as np
import torch

from experiments.scripts import ROOT, command_line, parse_args, run_main, write_result
from symgrasp.benchmark.runner import BOOTSTRAP
from symgrasp.detect import GraspDetector
from symgrasp.perception import CameraIntrinsic, default_extrinsic, depth_to_points
from symgrasp.serve.client import GraspClient
from symgrasp.sim.objects import object_set
from symgrasp.sim.render import make_renderer
from symgrasp.sim.world import pile_scene


def median_interval(values: list[float], seed: int = 0) -> tuple[float, float]:
    """The 95% percentile-bootstrap interval of the median of ``values``."""
    data = np.asarray(values)
    rng = np.random.default_rng(seed)
    medians = np.median(data[rng.integers(len(data), size=(BOOTSTRAP, len(data)))], axis=1)
    low, high = np.percentile(medians, [2.5, 97.5])
    return float(low), float(high)


def start_server(model: str, threads: int) -> tuple[subprocess.Popen, str]:
    """``symgrasp serve`` on a free loopback port, this checkout's code, and its URL."""
    env = {"OMP_NUM_THREADS": str(threads), **os.environ}
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT / "src"), env.get("PYTHONPATH")]))
    process = subprocess.Popen(
        [sys.executable, "-m", "symgrasp", "serve", "--port", "0", "--quiet", "--device", "cpu",
         "--model", model],
        stdout=subprocess.PIPE, text=True, env=env,
    )  # fmt: skip
    line = process.stdout.readline()
    if not line.startswith("listening on "):
        process.kill()
        raise RuntimeError(f"symgrasp serve did not start: {line!r}")
    return process, line.split()[2]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default="bingham2d-robotiq-2f85", help="model name or path")
    parser.add_argument("--requests", type=int, default=50, help="timed rounds (default: 50)")
    parser.add_argument(
        "--threads", type=int, default=1, help="torch threads, here and in the server (default: 1)"
    )
    parser.add_argument(
        "--result",
        default="benchmarks/results/serve",
        metavar="STEM",
        help="where the result goes: STEM.json and STEM.md (default: benchmarks/results/serve)",
    )
    args = parse_args(parser, outputs=("result",), quick={"requests": 3})
    torch.set_num_threads(args.threads)

    detector = GraspDetector.from_pretrained(args.model, device="cpu")
    world = pile_scene(object_set("household-test", 5, seed=0), seed=0, gripper=detector.gripper)
    intrinsic, T = CameraIntrinsic(), default_extrinsic()
    depth = make_renderer(intrinsic).render(world, T)
    cloud = depth_to_points(depth, intrinsic, T, crop=False).astype(np.float32)

    process, url = start_server(args.model, args.threads)
    try:
        ways = {
            "depth, in process": lambda: detector.detect(depth, intrinsic, T),
            "depth, server, base64": lambda: GraspClient(url).detect(depth, intrinsic, T),
            "depth, server, lists": lambda: GraspClient(url, encoding="lists").detect(
                depth, intrinsic, T
            ),
            "points, in process": lambda: detector.detect_points(cloud, T, intrinsic=intrinsic),
            "points, server, base64": lambda: GraspClient(url).detect_points(
                cloud, T, intrinsic=intrinsic
            ),
        }
        for call in ways.values():  # warm-up: caches, allocator, the server's first request
            call()
        times: dict[str, list[float]] = {name: [] for name in ways}
        server_ms: dict[str, list[float]] = {name: [] for name in ways if "server" in name}
        found: dict[str, int] = {}
        names = list(ways)
        for round_ in range(args.requests):
            for name in names if round_ % 2 == 0 else names[::-1]:
                start = time.perf_counter()
                answer = ways[name]()
                times[name].append(1e3 * (time.perf_counter() - start))
                if name in server_ms:
                    server_ms[name].append(answer.timing_ms["server"])
                    found[name] = len(answer.grasps)
                else:
                    found[name] = len(answer)
    finally:
        process.terminate()
        process.wait(timeout=60)

    cells = []
    for name in names:
        source = name.split(",")[0]
        cell = {
            "way": name,
            "grasps": found[name],
            "median_ms": statistics.median(times[name]),
            "best_ms": min(times[name]),
        }
        if name in server_ms:
            added = [
                t - here
                for t, here in zip(times[name], times[f"{source}, in process"], strict=True)
            ]
            cell["added_median_ms"] = statistics.median(added)
            cell["added_interval_ms"] = median_interval(added)
            cell["server_side_median_ms"] = statistics.median(server_ms[name])
        cells.append(cell)
    rows = [
        f"| {c['way']} | {c['median_ms']:.1f} | "
        + (
            f"{c['added_median_ms']:+.1f} [{c['added_interval_ms'][0]:+.1f}, "
            f"{c['added_interval_ms'][1]:+.1f}] | {c['server_side_median_ms']:.1f}"
            if "added_median_ms" in c
            else "– | –"
        )
        + f" | {c['grasps']} |"
        for c in cells
    ]
    table = (
        "| way | round trip, median ms | added, median [95% CI] ms | in the server, median ms | grasps |\n"
        "|---|---|---|---|---|\n" + "\n".join(rows) + "\n"
    )
    print(table, end="")
    write_result(
        args.result,
        "the grasp server's added latency: round trip minus the same detection in process",
        command_line(f"OMP_NUM_THREADS={os.environ.get('OMP_NUM_THREADS', '')} PYTHONPATH=src"),
        cells,
        table,
        model=args.model,
        depth_renderer="640×480, 5-object household-test pile, seed 0, default camera",
        points=len(cloud),
        statistic=f"medians of {args.requests} paired rounds after a warm-up; bootstrap "
        f"{BOOTSTRAP} resamples of the rounds",
    )


if __name__ == "__main__":
    run_main(main)
