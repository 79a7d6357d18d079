"""Why the wide-label detectors' grasps slip (issue 36: where a target is missed, the failure
modes say why) → experiments/results/slips.{json,md}.

    SYMGRASP_DATA=DIR PYTHONPATH=src python experiments/slips.py \\
        --models RUN/best.pt … [--recorded ROUNDS.jsonl …] [--rounds 60] [--work out/slips] \\
        [--objects SET] [--seed S] [--clearance M] [--result PATH] [--quick [DIR]]

The final campaign's detectors (trained on the ``wide`` spread labels) lose 7–12 % of their
executed grasps on the judging rounds to slips (closed on an object that is not held after the
lift, at every yaw the diagnosis tries); Table 1's detectors lost ≈ 1 %. Each checkpoint plays
the judging rounds' first ``--rounds`` again (``vgn-pile-train`` from round seed 2 000 000,
clean, under the approach rule they were judged with: −2 mm, `OLD_RULE`), or the rounds
``--objects``, ``--seed`` and ``--clearance`` name (a test cell: looked at, as here); with
``--recorded`` (a ``rounds.jsonl`` per model, in order) the replays are checked against the
recorded rounds attempt for attempt and the matches counted. Every executed grasp is measured
from the state it started in:

- **Grip**: the aimed object's surface (`failures.aimed_object`; `SURFACE_SAMPLES` points) in
  the TCP frame: how much of the open pads' length along the approach has object between the
  fingers (``pad_overlap_mm``: the pads' extent along ``e_x``, `common.pad_extent`, against
  the object's extent inside the closing slab), how much of their width along ``e_y``
  (``width_overlap_mm``), and the object's thickness across the closing axis there.
- **The network around the executed voxel**: its predicted validity at the voxels one and two
  steps deeper and shallower along the grasp's approach (the same image's outputs): does the
  detector execute the shallow edge of a blob of valid voxels?
- **Counterfactuals** for each slip: the same grasp (same rotation) played from the same state
  moved one and two voxels (7.5, 15 mm) deeper along ``e_x``: would a deeper TCP have held?

Rates carry Wilson 95 % intervals. Training objects and the judging rounds (chosen on, so looked
at, nothing chosen on them here). ``--work`` keeps each model's replayed rounds: a killed run
resumes. ``--quick``: the shipped model, one round.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np
from common import SHIPPED, Watched, add_result_option, pad_extent, records_by_seed, wilson
from scripts import command_line, parse_args, run_main, write_result
from tqdm import tqdm

from symgrasp.benchmark.declutter import run_round
from symgrasp.benchmark.failures import aimed_object
from symgrasp.detect.pretrained import resolve_model
from symgrasp.objects.sets import resolve
from symgrasp.peers.planners import load_planner
from symgrasp.sim.execute import execute_grasp
from symgrasp.workspace import RESOLUTION, VOXEL_SIZE

OLD_RULE = -0.002
"""The approach rule's clearances [m] the final campaign judged with (the default)."""

SEED = 2_000_000
"""The judging rounds' first seed (final.toml's ``judge``; the default)."""

OBJECTS = "vgn-pile-train"
"""The judging rounds' objects (the default)."""

SURFACE_SAMPLES = 4096
"""Surface points of the aimed object: ≈ 1 mm apart on a 6 cm object."""

STEPS = (-2, -1, 1, 2)
"""Voxel steps along the approach at which the network's validity is read."""

DEEPER = (1, 2)
"""Voxel steps deeper along the approach at which each slip is played again."""


class WatchedOutputs(Watched):
    """`common.Watched` that also keeps the network's outputs for the image it planned on."""

    def plan(self, observation: Any) -> list:
        volume = self.planner.fuse(
            observation.depth, observation.intrinsic, observation.T_world_camera
        )
        self.outputs = self.planner.predict(volume.grid())
        return super().plan(observation)


def grip(points: np.ndarray, T: np.ndarray, pad_x: tuple, pad_y: tuple, width: float) -> dict:
    """The aimed object's surface ``points`` (P, 3, world) against the open hand at ``T``
    (T_world_tcp): the pads' overlap with it along ``e_x`` and ``e_y`` and its thickness
    along ``e_z`` between the pads [mm]; None where no point lies between the fingers."""
    local = (points - T[:3, 3]) @ T[:3, :3]
    between = np.abs(local[:, 2]) <= width / 2
    beside_x = between & (local[:, 1] >= pad_y[0]) & (local[:, 1] <= pad_y[1])
    beside_y = between & (local[:, 0] >= pad_x[0]) & (local[:, 0] <= pad_x[1])

    def overlap(values: np.ndarray, span: tuple) -> float | None:
        if not values.size:
            return None
        return 1000 * max(0.0, min(span[1], values.max()) - max(span[0], values.min()))

    held = local[beside_x & beside_y]
    return {
        "pad_overlap_mm": overlap(local[beside_x, 0], pad_x),
        "width_overlap_mm": overlap(local[beside_y, 1], pad_y),
        "thickness_mm": 1000 * float(np.ptp(held[:, 2])) if len(held) else None,
    }


def validity_along(outputs: dict, voxel: tuple, e_x: np.ndarray) -> dict[str, float | None]:
    """The predicted validity at ``STEPS`` voxels along ``e_x`` from ``voxel`` (nearest voxel;
    None outside the grid)."""
    validity = outputs["validity"].cpu().numpy()
    row = {}
    for k in STEPS:
        index = np.rint(np.asarray(voxel) + k * e_x).astype(int)
        inside = bool(np.all((index >= 0) & (index < RESOLUTION)))
        row[f"validity_{k:+d}"] = float(validity[tuple(index)]) if inside else None
    row["validity_0"] = float(validity[tuple(voxel)])
    return row


def deeper(T: np.ndarray, steps: int) -> np.ndarray:
    """``T`` moved ``steps`` voxels along its own approach axis."""
    moved = T.copy()
    moved[:3, 3] += steps * VOXEL_SIZE * T[:3, 0]
    return moved


def replay_round(
    watched: WatchedOutputs, objects: Any, seed: int, hand: dict, clearance: float
) -> dict[str, Any]:
    """Round ``seed`` played again under the approach rule ``clearance`` [m] (table and
    observed surface) with every executed grasp measured (module docstring)."""
    rows = []

    def observe(world: Any, points: np.ndarray, candidates: list, attempt: Any) -> None:
        if attempt.grasp is None:
            return
        T, start = attempt.grasp.pose, watched.world()
        aimed = aimed_object(start, T)
        spec, T_world_object = start.objects[aimed], start.object_poses()[aimed]
        surface = spec.sample_surface(SURFACE_SAMPLES)[0] @ T_world_object[:3, :3].T
        row = {"outcome": attempt.outcome, "mode": attempt.mode}
        row |= grip(surface + T_world_object[:3, 3], T, **hand)
        row |= validity_along(watched.outputs, attempt.grasp.voxel, T[:3, 0])
        if attempt.mode == "slip":
            row["deeper"] = {
                str(k): execute_grasp(watched.world(), deeper(T, k), remove=False).outcome.value
                for k in DEEPER
            }
        rows.append(row)

    record = run_round(watched, objects, seed=seed, observer=observe,
                       table_clearance=clearance, surface_clearance=clearance)  # fmt: skip
    return {"seed": seed, "attempts": [a.outcome for a in record.attempts], "rows": rows}


def replays(model: str, args: argparse.Namespace, path: Path) -> list[dict[str, Any]]:
    """Rounds ``--seed`` … ``--seed + --rounds − 1`` of ``model`` on ``--objects`` under
    ``--clearance``, from ``path`` where already played, the rest played and appended."""
    seeds = [args.seed + i for i in range(args.rounds)]
    done = records_by_seed(path)
    todo = [seed for seed in seeds if seed not in done]
    if todo:
        planner = load_planner(str(resolve_model(model)), device="cpu")
        watched = WatchedOutputs(planner)
        hand = {"pad_x": pad_extent(planner.gripper), "pad_y": pad_extent(planner.gripper, 1),
                "width": planner.gripper.max_width}  # fmt: skip
        objects = resolve(args.objects)
        path.parent.mkdir(parents=True, exist_ok=True)
        with path.open("a") as out:
            for seed in tqdm(todo, desc=Path(model).parent.name or model, unit="round"):
                record = replay_round(watched, objects, seed, hand, args.clearance)
                out.write(json.dumps(record) + "\n")
                out.flush()
                done[seed] = record
    return [done[seed] for seed in seeds]


def matches(records: list[dict[str, Any]], recorded: Path) -> int:
    """How many replayed rounds repeat ``recorded``'s outcomes attempt for attempt."""
    kept = {seed: [a["outcome"] for a in r["attempts"]]
            for seed, r in records_by_seed(recorded).items()}  # fmt: skip
    return sum(kept.get(r["seed"]) == r["attempts"] for r in records)


def median(values: list) -> float | None:
    kept = [v for v in values if v is not None]
    return float(np.median(kept)) if kept else None


def share(rows: list[dict], test: Any) -> dict[str, Any]:
    k = sum(bool(test(r)) for r in rows)
    return {"k": k, "n": len(rows), "ci95": wilson(k, len(rows)) if rows else None}


def summarise(rows: list[dict], threshold: float) -> dict[str, Any]:
    """Per-group medians and shares (module docstring)."""
    return {
        "attempts": len(rows),
        "median_pad_overlap_mm": median([r["pad_overlap_mm"] for r in rows]),
        "median_width_overlap_mm": median([r["width_overlap_mm"] for r in rows]),
        "median_thickness_mm": median([r["thickness_mm"] for r in rows]),
        "valid_deeper": share(rows, lambda r: (r["validity_+1"] or 0) >= threshold),
        "valid_shallower": share(rows, lambda r: (r["validity_-1"] or 0) >= threshold),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", nargs="+", default=[SHIPPED],
                        help="checkpoints (or shipped model names) to play (default: %(default)s)")  # fmt: skip
    parser.add_argument("--recorded", nargs="*", default=[],
                        help="each model's recorded judging rounds.jsonl, in --models' order "
                             "('-' for none), to check the replays against")  # fmt: skip
    parser.add_argument("--rounds", type=int, default=60, help="rounds per model (default: 60)")
    parser.add_argument("--objects", default=OBJECTS,
                        help="object set of the rounds (default: %(default)s, the judging rounds')")  # fmt: skip
    parser.add_argument("--seed", type=int, default=SEED,
                        help="first round seed (default: %(default)s, the judging rounds')")  # fmt: skip
    parser.add_argument("--clearance", type=float, default=OLD_RULE,
                        help="the approach rule's table and surface clearance [m] (default: "
                        "%(default)s, the judging rounds'; today's benchmark: 0.001)")  # fmt: skip
    parser.add_argument("--work", default="out/slips",
                        help="folder of each model's replayed rounds, kept to resume (default: %(default)s)")  # fmt: skip
    add_result_option(parser, "slips")
    args = parse_args(parser, outputs=("work", "result"), quick={"rounds": 1, "models": [SHIPPED]})
    if args.recorded and len(args.recorded) != len(args.models):
        parser.error(f"--recorded: expected one file per model ({len(args.models)}), "
                     f"got {len(args.recorded)}")  # fmt: skip

    cells = []
    for index, model in enumerate(args.models):
        path = resolve_model(model)
        name = f"{path.parent.name}/{path.stem}" if Path(model).is_file() else str(model)
        folder = Path(args.work) / f"{args.objects}-{args.seed}-{args.clearance:g}"
        records = replays(
            model, args, folder / f"{index:02d}-{Path(model).parent.name or model}.jsonl"
        )
        threshold = load_planner(str(path), device="cpu").validity_threshold
        rows = [row for r in records for row in r["rows"]]
        slips = [r for r in rows if r["mode"] == "slip"]
        cell = {
            "model": name,
            "rounds": len(records),
            "executed": len(rows),
            "slips": share(rows, lambda r: r["mode"] == "slip"),
            "by_mode": {
                mode: summarise([r for r in rows if r["mode"] == mode], threshold)
                for mode in ("success", "slip")
            },
            "slip_deeper_holds": {
                str(k): share(slips, lambda r, k=k: r["deeper"][str(k)] == "success")
                for k in DEEPER
            },
        }
        if args.recorded and args.recorded[index] != "-":
            cell["rounds_repeating_recorded"] = matches(records, Path(args.recorded[index]))
        cells.append(cell)

    text = ["| model | executed | slips | group | pad overlap (median) | width overlap | "
            "thickness | valid 1 voxel deeper | valid 1 voxel shallower |",
            "|---|---|---|---|---|---|---|---|---|"]  # fmt: skip

    def pct(s: dict) -> str:
        if not s["n"]:
            return "–"
        lo, hi = s["ci95"]
        return f"{100 * s['k'] / s['n']:.0f} % [{lo:.0f}, {hi:.0f}]"

    def mm(v: float | None) -> str:
        return "–" if v is None else f"{v:.1f} mm"

    for c in cells:
        for mode, g in c["by_mode"].items():
            text.append(f"| {c['model']} | {c['executed']} | {pct(c['slips'])} | {mode} ({g['attempts']}) "
                        f"| {mm(g['median_pad_overlap_mm'])} | {mm(g['median_width_overlap_mm'])} "
                        f"| {mm(g['median_thickness_mm'])} | {pct(g['valid_deeper'])} "
                        f"| {pct(g['valid_shallower'])} |")  # fmt: skip
    text += ["", "| model | slips played 1 voxel deeper: held | 2 voxels deeper: held |",
             "|---|---|---|"]  # fmt: skip
    for c in cells:
        held = c["slip_deeper_holds"]
        text.append(f"| {c['model']} | {pct(held['1'])} | {pct(held['2'])} |")
    table = "\n".join(text) + "\n"
    print(table)
    write_result(
        args.result,
        "executed grasps of the judging rounds: grip, the network around them, slips deeper",
        command_line("SYMGRASP_DATA=DIR PYTHONPATH=src"),
        cells,
        table,
        rounds=args.rounds,
        seed=args.seed,
        objects=args.objects,
        approach_rule_played=args.clearance,
    )


if __name__ == "__main__":
    run_main(main)
