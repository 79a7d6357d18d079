"""Data generation on a Ray cluster against the process pool → experiments/results/scale.json.

    PYTHONPATH=src python experiments/scale.py [--scenes 100] [--pool 4] [--noop 2000] \
        [--repeats 3] [--quick [DIR]]

On this machine, for the process pool and for Ray (a local instance of as many CPUs as
workers, started before and stopped after each run), each with 1 and 2 workers, the four runs
interleaved and repeated --repeats times, each number the best of its repeats (on a shared
machine, the least disturbed):

- wall seconds of `symgrasp.data.generate.generate` writing --scenes labelled scenes of the
  default scene configuration over a pool of --pool objects (databases built once beforehand
  and copied into every run, so the runs time scenes only; the workers' start, importing
  torch and MuJoCo, is inside, as in a real run); seconds per scene; the scaling efficiency
  T(1 worker) / (2 · T(2 workers)); whether every run wrote the same dataset (its hash);
- Ray's start (``ray.init`` of the local instance), outside the runs;
- the overhead per task: the extra wall seconds per task of mapping a no-op (``abs``) over
  --noop arguments instead of a tenth of them (a difference, so the workers' start cancels);
- a 1 M-scene dataset extrapolated from the 2-worker Ray run: core-hours (seconds per scene
  per worker × 10⁶) and disk (mean scene file × 10⁶).
"""

from __future__ import annotations

import argparse
import shutil
import time
from pathlib import Path

from common import add_result_option
from scripts import command_line, parse_args, run_main, write_result

from symgrasp.config import DatabaseConfig, ParallelConfig, SceneConfig
from symgrasp.parallel import Job, open_executor
from symgrasp.parallel.cluster import import_ray

RUNS = (("process", 1), ("process", 2), ("ray", 1), ("ray", 2))
MILLION = 1_000_000


def _noop_seconds_per_task(parallel: ParallelConfig, tasks: int) -> float:
    """Extra wall seconds per task of ``tasks`` no-op tasks over ``tasks // 10`` of them."""
    seconds = []
    for n in (tasks // 10, tasks):
        with open_executor(parallel) as executor:
            start = time.perf_counter()
            for _ in executor.map(Job(abs), range(n), f"no-op ×{n}"):
                pass
            seconds.append(time.perf_counter() - start)
    return (seconds[1] - seconds[0]) / (tasks - tasks // 10)


def _run(backend: str, workers: int, cfg: SceneConfig, args: argparse.Namespace) -> dict:
    """One cell: generation and no-op overhead with ``workers`` workers of ``backend``."""
    from symgrasp.data.generate import generate  # here: the pool's workers re-import this script

    out = Path(args.out) / f"{backend}-{workers}"
    shutil.rmtree(out, ignore_errors=True)
    shutil.copytree(Path(args.out) / "databases" / "db", out / "db")
    parallel = ParallelConfig(backend, workers)
    cell: dict = {"backend": backend, "workers": workers}
    if backend == "ray":  # started here, so that generate joins it and the runs time work only
        ray = import_ray()
        start = time.perf_counter()
        ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False)
        cell["ray_start_seconds"] = time.perf_counter() - start
    try:
        start = time.perf_counter()
        manifest = generate(out, cfg, args.scenes, parallel=parallel)
        cell["wall_seconds"] = time.perf_counter() - start
        cell["noop_ms_per_task"] = 1000 * _noop_seconds_per_task(parallel, args.noop)
    finally:
        if backend == "ray":
            ray.shutdown()
    cell["seconds_per_scene"] = cell["wall_seconds"] / args.scenes
    cell["seconds_per_scene_per_worker"] = cell["seconds_per_scene"] * workers
    cell["dataset_hash"] = manifest["dataset_hash"]
    files = list((out / "scenes").glob("*.npz"))
    cell["mean_scene_bytes"] = sum(f.stat().st_size for f in files) / len(files)
    print({k: round(v, 4) if isinstance(v, float) else v for k, v in cell.items()})
    return cell


def _best(runs: list[dict]) -> dict:
    """One cell from its repeats: each time the least, the rest as measured."""
    cell = {**runs[0], "repeats": len(runs)}
    for key in ("ray_start_seconds", "wall_seconds", "noop_ms_per_task"):
        if key in cell:
            cell[f"{key}_all"] = [r[key] for r in runs]
            cell[key] = min(cell[f"{key}_all"])
    cell["seconds_per_scene"] = min(r["seconds_per_scene"] for r in runs)
    cell["seconds_per_scene_per_worker"] = cell["seconds_per_scene"] * cell["workers"]
    return cell


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", type=int, default=100, help="scenes per run (default: 100)")
    parser.add_argument("--repeats", type=int, default=3, help="runs per cell (default: 3)")
    parser.add_argument("--pool", type=int, default=4, help="objects in the pool (default: 4)")
    parser.add_argument("--grasps", type=int, default=300, help="grasps per database")
    parser.add_argument("--directions", type=int, default=32, help="score directions")
    parser.add_argument("--noop", type=int, default=2000, help="no-op tasks (default: 2000)")
    parser.add_argument("--out", default="out/bench-scale", help="work folder")
    add_result_option(parser, "scale")
    args = parse_args(
        parser,
        outputs=("out", "result"),
        quick={"scenes": 4, "pool": 2, "grasps": 10, "directions": 4, "noop": 40, "repeats": 1},
    )
    import_ray()  # half of the runs are Ray's: without it, stop before building anything
    database = DatabaseConfig(grasps=args.grasps, directions=args.directions)
    cfg = SceneConfig(pool_size=args.pool, database=database)
    from symgrasp.data.generate import generate

    generate(Path(args.out) / "databases", cfg, 1, resume=True)
    runs = [
        _run(backend, workers, cfg, args) for _ in range(args.repeats) for backend, workers in RUNS
    ]
    cells = [_best([r for r in runs if (r["backend"], r["workers"]) == run]) for run in RUNS]

    by = {(c["backend"], c["workers"]): c for c in cells}
    for backend in ("process", "ray"):
        one, two = by[backend, 1]["wall_seconds"], by[backend, 2]["wall_seconds"]
        by[backend, 2]["scaling_efficiency"] = one / (2 * two)
    for workers in (1, 2):
        ray, pool = by["ray", workers], by["process", workers]
        ray["overhead_seconds_per_scene_vs_process"] = (
            ray["seconds_per_scene"] - pool["seconds_per_scene"]
        )
    ray2 = by["ray", 2]
    million = {
        "core_hours": ray2["seconds_per_scene_per_worker"] * MILLION / 3600,
        "disk_gb": ray2["mean_scene_bytes"] * MILLION / 1e9,
        "how": "seconds per scene per worker of the 2-worker Ray run × 10⁶ (databases, "
        "16 × ≈ 35 s, left out), mean scene file × 10⁶; extrapolated, not run",
    }
    rows = "".join(
        f"| {c['backend']} | {c['workers']} | {c['wall_seconds']:.1f} | "
        f"{c['seconds_per_scene']:.3f} | {c.get('scaling_efficiency', float('nan')):.2f} | "
        f"{c['noop_ms_per_task']:.2f} |\n"
        for c in cells
    )
    table = (
        "| backend | workers | wall s | s per scene | scaling efficiency | no-op ms per task |\n"
        "|---|---|---|---|---|---|\n" + rows
    )
    print(table)
    write_result(
        args.result,
        "data generation: Ray backend vs process pool, 1 and 2 workers",
        command_line("PYTHONPATH=src"),
        cells,
        table,
        same_bytes=len({r["dataset_hash"] for r in runs}) == 1,
        one_million_scenes=million,
    )


if __name__ == "__main__":
    run_main(main)
