"""Cost of a grasp database per held grasp, against the step-by-step force ramps it replaced
→ benchmarks/results/grasp_db.json.

    SYMGRASP_DATA=../shared PYTHONPATH=src python benchmarks/grasp_db.py [--objects 3]
        [--grasps 150] [--directions 16] [--repeats 1] [--out ...] [--quick [DIR]]

Cells: a procedural box (4 × 6 × 9 cm, 0.2 kg, μ 0.5, the box of tests/data) and the first
``--objects`` objects of the training pool of VGN's meshes (``vgn-pile-train,vgn-packed-train``,
pool seed 0, the databases of the VGN datasets), each with both grippers; seed = the object's
index; ``--grasps`` and ``--directions`` default to what VGN's sets use (docs/data.md). Each
cell builds its database with `build_database` twice per repeat, in alternating order so that a
change of the shared machine's load falls on both:

- **before**: the force ramps stepped one `World.step` at a time through `World`'s interface
  (`apply_force`, `step`, `hand_pose`, `object_positions`), the code before
  `World.push_until_slip` (`symgrasp.sim.execute.stepwise_pull_out_forces`);
- **after**: the code as it is.

The fastest of the repeats counts. One more build (after) measures the shares of its time
spent inside MuJoCo (`mj_step`, `mj_forward`, through a timing wrapper) and in the force ramps
(`pull_out_forces`). The MuJoCo share of the fastest after is what the same steps cost with no
Python at all, so ``before / MuJoCo`` bounds any speed-up that leaves the physics, and so the
database, as it is; the rest without the ramps' share is what a database would cost that
scored nothing (closures, sampling, bookkeeping). (Shares, not seconds: a load that changes
between builds slows MuJoCo and Python alike.) Reports seconds per held grasp, the ratio before/after
per cell and over the cells (total seconds, bootstrap 95 % interval over cells), and whether the
two databases are equal bit for bit. One process, one core: MuJoCo steps on the calling thread.
Needs VGN's object sets (``symgrasp objects fetch vgn``); stops with exit status 66 without them.

``--quick``: one VGN object, 2 grasps, 4 directions.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import time

import lab  # noqa: F401  (puts the checkout's root on sys.path, for experiments.scripts)
import mujoco
import numpy as np

from experiments.scripts import command_line, parse_args, run_main, write_result
from symgrasp.benchmark.runner import BOOTSTRAP
from symgrasp.config import DatabaseConfig
from symgrasp.data import grasp_db
from symgrasp.data.grasp_db import GraspDatabase, build_database
from symgrasp.names import GRIPPERS
from symgrasp.objects.sets import resolve
from symgrasp.sim.execute import stepwise_pull_out_forces
from symgrasp.sim.grippers import get_gripper
from symgrasp.sim.objects import ObjectSpec, Part

OBJECTS = "vgn-pile-train,vgn-packed-train"
BOX_HALF = (0.02, 0.03, 0.045)
FAST_RAMPS = grasp_db.pull_out_forces


class MujocoClock:
    """Seconds spent inside ``mujoco.mj_step`` and ``mujoco.mj_forward`` while entered."""

    NAMES = ("mj_step", "mj_forward")

    def __init__(self) -> None:
        self.seconds = 0.0
        self._originals = {name: getattr(mujoco, name) for name in self.NAMES}

    def _timed(self, function):
        def timed(*args, **kwargs):
            start = time.perf_counter()
            function(*args, **kwargs)
            self.seconds += time.perf_counter() - start

        return timed

    def __enter__(self) -> MujocoClock:
        for name, function in self._originals.items():
            setattr(mujoco, name, self._timed(function))
        return self

    def __exit__(self, *exc) -> None:
        for name, function in self._originals.items():
            setattr(mujoco, name, function)


def _build(obj: ObjectSpec, hand, cfg: DatabaseConfig, seed: int, ramps):
    """The database and the seconds it took, its force ramps run by ``ramps``."""
    grasp_db.pull_out_forces = ramps
    try:
        start = time.perf_counter()
        db = build_database(obj, hand, cfg, seed)
        return db, time.perf_counter() - start
    finally:
        grasp_db.pull_out_forces = FAST_RAMPS


def _same(a: GraspDatabase, b: GraspDatabase) -> bool:
    return all(
        np.array_equal(getattr(a, f.name), getattr(b, f.name)) for f in dataclasses.fields(a)
    )


def measure_cell(
    obj: ObjectSpec, kind: str, gripper: str, seed: int, cfg: DatabaseConfig, repeats: int
) -> dict:
    hand = get_gripper(gripper)
    ramps = {"before": stepwise_pull_out_forces, "after": FAST_RAMPS}
    seconds: dict[str, list[float]] = {"before": [], "after": []}
    built: dict[str, GraspDatabase] = {}
    for r in range(repeats):
        order = ("before", "after") if (seed + r) % 2 == 0 else ("after", "before")
        for variant in order:
            built[variant], elapsed = _build(obj, hand, cfg, seed, ramps[variant])
            seconds[variant].append(elapsed)
    in_ramps = 0.0

    def timed_ramps(*args):
        nonlocal in_ramps
        start = time.perf_counter()
        forces = FAST_RAMPS(*args)
        in_ramps += time.perf_counter() - start
        return forces

    with MujocoClock() as clock:
        _, clocked = _build(obj, hand, cfg, seed, timed_ramps)
    held = int(built["after"].held.sum())
    before, after = min(seconds["before"]), min(seconds["after"])
    in_mujoco = after * clock.seconds / clocked
    without_ramps = after * (1 - in_ramps / clocked)
    cell = {
        "object": obj.name,
        "kind": kind,
        "gripper": gripper,
        "parts": len(obj.parts),
        "mass_kg": round(obj.mass, 4),
        "closures": built["after"].candidates,
        "held": held,
        "seconds_before": round(before, 3),
        "seconds_after": round(after, 3),
        "share_in_mujoco": round(clock.seconds / clocked, 3),
        "share_in_ramps": round(in_ramps / clocked, 3),
        "seconds_without_ramps": round(without_ramps, 3),
        "seconds_in_mujoco": round(in_mujoco, 3),
        "ms_per_grasp_before": round(1e3 * before / held, 2),
        "ms_per_grasp_after": round(1e3 * after / held, 2),
        "ms_per_grasp_in_mujoco": round(1e3 * in_mujoco / held, 2),
        "ms_per_grasp_without_ramps": round(1e3 * without_ramps / held, 2),
        "ratio": round(before / after, 2),
        "ratio_bound_same_physics": round(before / in_mujoco, 2),
        "identical": _same(built["before"], built["after"]),
        "load_average_1min": round(os.getloadavg()[0], 2),
    }
    print(cell)
    return cell


def summary(cells: list[dict], rng: np.random.Generator) -> dict:
    """Seconds per held grasp before and after over ``cells``, the ratio of their totals and
    its bootstrap 95 % interval over cells."""
    before = np.array([c["seconds_before"] for c in cells])
    after = np.array([c["seconds_after"] for c in cells])
    mujoco_s = np.array([c["seconds_in_mujoco"] for c in cells])
    unscored = np.array([c["seconds_without_ramps"] for c in cells])
    held = np.array([c["held"] for c in cells])
    picks = rng.integers(len(cells), size=(BOOTSTRAP, len(cells)))
    ratios = before[picks].sum(axis=1) / after[picks].sum(axis=1)
    return {
        "cells": len(cells),
        "ms_per_grasp_before": round(1e3 * before.sum() / held.sum(), 2),
        "ms_per_grasp_after": round(1e3 * after.sum() / held.sum(), 2),
        "ms_per_grasp_in_mujoco": round(1e3 * mujoco_s.sum() / held.sum(), 2),
        "ms_per_grasp_without_ramps": round(1e3 * unscored.sum() / held.sum(), 2),
        "ratio": round(before.sum() / after.sum(), 2),
        "ratio_interval_95": [round(float(q), 2) for q in np.quantile(ratios, [0.025, 0.975])],
        "ratio_bound_same_physics": round(before.sum() / mujoco_s.sum(), 2),
        "share_of_after_in_mujoco": round(mujoco_s.sum() / after.sum(), 3),
        "ratio_before_to_without_ramps": round(before.sum() / unscored.sum(), 2),
        "identical": all(c["identical"] for c in cells),
    }


def table(result: dict) -> str:
    rows = [
        "| cells | ms per grasp, before | after | in MuJoCo | without ramps "
        "| before / after [95 %] | before / MuJoCo | databases equal |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name, s in result.items():
        lo, hi = s["ratio_interval_95"]
        rows.append(
            f"| {name} ({s['cells']}) | {s['ms_per_grasp_before']} | {s['ms_per_grasp_after']} "
            f"| {s['ms_per_grasp_in_mujoco']} | {s['ms_per_grasp_without_ramps']} "
            f"| {s['ratio']} [{lo}, {hi}] "
            f"| {s['ratio_bound_same_physics']} | {s['identical']} |"
        )
    return "\n".join(rows) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--objects", type=int, default=3, help="VGN objects (cells per gripper)")
    parser.add_argument("--grasps", type=int, default=150, help="held grasps per database")
    parser.add_argument("--directions", type=int, default=16, help="ramp directions K")
    parser.add_argument(
        "--repeats", type=int, default=1, help="builds per variant and cell; the fastest counts"
    )
    parser.add_argument("--out", default="benchmarks/results/grasp_db.json", help="result file")
    args = parse_args(parser, outputs=("out",), quick={"objects": 1, "grasps": 2, "directions": 4})
    vgn = resolve(OBJECTS).pool(args.objects, 0)  # first: no work without the data
    box = ObjectSpec("box", "box", (Part("box", BOX_HALF, (0, 0, BOX_HALF[2])),), 0.2, 0.5)
    cfg = DatabaseConfig(grasps=args.grasps, directions=args.directions)
    cells = []
    for gripper in GRIPPERS:
        cells.append(measure_cell(box, "procedural", gripper, 0, cfg, args.repeats))
        for k, obj in enumerate(vgn):
            cells.append(measure_cell(obj, "vgn", gripper, k, cfg, args.repeats))
    rng = np.random.default_rng(0)
    summaries = {
        "vgn": summary([c for c in cells if c["kind"] == "vgn"], rng),
        "procedural": summary([c for c in cells if c["kind"] == "procedural"], rng),
        "all": summary(cells, rng),
    }
    print(table(summaries))
    write_result(
        str(args.out).removesuffix(".json"),
        "grasp database cost per held grasp, before and after the fast force ramps",
        command_line(""),
        cells,
        table(summaries),
        objects=OBJECTS,
        summary=summaries,
    )


if __name__ == "__main__":
    run_main(main)
