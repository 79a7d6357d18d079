"""Labels dense enough to learn from: how far a held grasp's TCP may move, how many voxels a
spread labels and whether they hold, and how often a voxel trained as invalid holds a grasp
→ experiments/results/label_density.{json,md}.

    SYMGRASP_DATA=../shared PYTHONPATH=src python experiments/label_density.py
        [--objects vgn-pile-train household-train] [--spreads 1,1,1,1 1,2,1,1 ...] [--offset LO HI]
        [--quick [DIR]]

Training objects only (the spread is chosen on these). For each object set: a pool of
``--pool`` objects whose databases hold ``--more-grasps`` held grasps (K = ``--directions``:
no score is measured here); their first ``--grasps`` (150, as VGN's datasets; the same seed
makes exactly the smaller database) are today's. VGN's pile and packed scenes, built by
`symgrasp.data.scenes.labelled_scene`:

1. **Tolerance** (scene ids 0 … ``--tolerance-scenes`` − 1). ``--tolerance-grasps`` surviving
   grasps per scene are moved by whole voxels (7.5 mm, up to ``--max-shift``) along e_x, e_y
   and e_z of their own frame; a moved grasp whose open hand fails the scene's collision check
   (the labels' own) would not be a label and is not run; the others run a grasp trial
   (`symgrasp.sim.execute.execute_grasp`) from the same settled state. Success per axis and
   move among those, with Wilson 95 % intervals.
2. **Label sets** (other scenes: ids 1000 …, ``--scenes`` of them): today's labels (the voxel
   of each TCP), each of ``--spreads`` (voxels back and forward along e_x, either way along
   e_y and e_z: `SceneConfig.label_spread`), and the ``--more-grasps`` databases without and
   with the first spread. Per set: valid voxels and rotation targets per scene, the seconds
   the spread's collision checks take, and ``--trials`` grasp trials at its voxels (a voxel
   drawn uniformly over the scenes' voxels, one of its rotation targets drawn uniformly, the
   TCP at the voxel's centre, where the detector puts it), at all its voxels and at those it
   adds to today's; and, as `symgrasp.data.validate` checks labels, today's surviving grasps
   at their own TCP.
3. **False negatives.** ``--negatives`` voxels drawn uniformly among those today's labels leave
   invalid near an object: centre above the table, within the distance of an object's surface
   (its collision-check samples) that holds 95 % of today's valid voxels. At each, the best
   candidate grasp we can name: of the scene's database grasps (every held grasp of its
   objects, colliding or not) the nearest to the centre whose open hand, moved there with its
   rotation, passes the collision check; one trial. The share that holds is a lower bound on
   how often a voxel trained as invalid holds a grasp (one candidate, one rotation): by the
   Chebyshev distance to the nearest valid voxel (what an ignore band of the validity loss
   leaves out), by whether a database grasp was tried in the voxel (a VGN-style mask), and,
   for each label set, among the same voxels it still leaves invalid.

``--quick``: one object set of two objects, tiny databases, two scenes, a few trials.
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path
from typing import Any

import numpy as np
import torch
from common import add_result_option, prefix, wilson
from scipy.spatial import cKDTree
from scripts import command_line, parse_args, run_main, write_result
from tqdm import tqdm

from symgrasp.config import DatabaseConfig, SceneConfig
from symgrasp.data.grasp_db import cached_database
from symgrasp.data.labels import VoxelLabels, added_voxels, voxel_centre, voxel_grasp, voxel_of
from symgrasp.data.scenes import LabelledScene, labelled_scene, scene_pool, spread_labels
from symgrasp.sim import World, execute_grasp
from symgrasp.sim.collision import hand_collides
from symgrasp.sim.grippers import GripperSpec, get_gripper
from symgrasp.workspace import RESOLUTION, TABLE_HEIGHT, VOXEL_SIZE

AXES = ("e_x", "e_y", "e_z")
TODAY = "today"
EVALUATION_SCENE = 1000
"""Scene id 0 of the label sets and false negatives: not a scene the tolerance was read on."""
SURFACE_QUANTILE = 0.95
"""The near-surface band holds this share of today's valid voxels."""
NEAREST = 16
"""Database grasps, nearest first, tried as a false-negative voxel's candidate."""
DISTANCES = (("1", 1, 1), ("2", 2, 2), ("3 or more", 3, RESOLUTION))
"""Chebyshev distance bins [voxels] to the nearest valid voxel."""
GRID = np.stack(np.meshgrid(*[np.arange(RESOLUTION)] * 3, indexing="ij"), -1).reshape(-1, 3)


def spread_name(spread: tuple[float, ...]) -> str:
    return "spread " + ",".join(f"{x:g}" for x in spread)


@dataclasses.dataclass
class Scene:
    """A scene with today's labels (``today``), its other label sets by name (``labels``, with
    the seconds their spread took), and a world with the hand to run trials in."""

    today: LabelledScene
    labels: dict[str, VoxelLabels]
    seconds: dict[str, float]
    world: World
    start: Any

    def collides(self, poses: np.ndarray, hand: GripperSpec, cfg: SceneConfig) -> np.ndarray:
        """The scene's collision check of poses (N, 4, 4), the one the labels passed."""
        return hand_collides(poses, hand, self.today.grasps["points"], -cfg.clearance)

    def holds(self, pose: np.ndarray) -> bool:
        """One grasp trial at ``pose`` from the settled state."""
        self.world.restore(self.start)
        return execute_grasp(self.world, pose, remove=False).success


def spread_of(
    scene: LabelledScene, cfg: SceneConfig, hand: GripperSpec
) -> tuple[VoxelLabels, float]:
    """The labels of ``scene``'s surviving grasps with ``cfg``'s spread, and their seconds."""
    g, ok = scene.grasps, scene.survivors
    start = time.perf_counter()
    labels = spread_labels(
        g["T_world_tcp"][ok], g["score"][ok], g["width"][ok], cfg,
        lambda T: hand_collides(T, hand, g["points"], -cfg.clearance),
    )  # fmt: skip
    return labels, time.perf_counter() - start


def build_scene(
    scene_id: int,
    cfg: SceneConfig,
    spreads: list[tuple[float, ...]],
    hand: GripperSpec,
    pool,
    databases: dict[str, list],
    more: str | None,
) -> Scene:
    """Scene ``scene_id`` with today's labels, each spread's, and (``more``: the name of the
    larger databases' sets) those of ``databases["more"]`` without and with the first spread."""
    today, _ = labelled_scene(scene_id, cfg, hand, pool, databases[TODAY])
    labels, seconds = {TODAY: today.labels}, {TODAY: 0.0}
    for spread in spreads:
        scfg = dataclasses.replace(cfg, label_spread=tuple(x * VOXEL_SIZE for x in spread))
        labels[spread_name(spread)], seconds[spread_name(spread)] = spread_of(today, scfg, hand)
    if more is not None:
        larger, _ = labelled_scene(scene_id, cfg, hand, pool, databases["more"])
        scfg = dataclasses.replace(cfg, label_spread=tuple(x * VOXEL_SIZE for x in spreads[0]))
        labels[more], seconds[more] = larger.labels, 0.0
        name = f"{more}, {spread_name(spreads[0])}"
        labels[name], seconds[name] = spread_of(larger, scfg, hand)
    world = World(today.world.objects, today.poses, gripper=hand)
    return Scene(today, labels, seconds, world, world.snapshot())


def rate(k: int, n: int) -> dict[str, Any]:
    return {"success": int(k), "trials": int(n), "pct": round(100 * k / n, 1) if n else None,
            "ci95": wilson(k, n)}  # fmt: skip


def tolerance(scenes: list[Scene], hand, cfg, args, rng) -> dict[str, Any]:
    """Success of surviving grasps moved by whole voxels along each axis of their frame."""
    shifts = [s for s in range(-args.max_shift, args.max_shift + 1) if s]
    counts = {key: [0, 0, 0] for key in [("unmoved", 0)] + [(a, s) for a in AXES for s in shifts]}
    for scene in tqdm(scenes, desc="tolerance", unit="scene"):
        poses = scene.today.grasps["T_world_tcp"][scene.today.survivors]
        for g in rng.permutation(len(poses))[: args.tolerance_grasps]:
            for key in counts:
                axis, s = key
                T = poses[g].copy()
                if s:
                    T[:3, 3] += s * VOXEL_SIZE * T[:3, AXES.index(axis)]
                counts[key][0] += 1  # moved (the unmoved grasp survives by definition)
                if s and scene.collides(T[None], hand, cfg)[0]:
                    continue
                counts[key][1] += 1
                counts[key][2] += scene.holds(T)
    return {
        f"{axis} {s:+d}": {"moved": c[0], "free": c[1], **rate(c[2], c[1])}
        for (axis, s), c in counts.items()
    }


def voxel_keys(labels: VoxelLabels, which: np.ndarray | None = None) -> set[tuple[int, int, int]]:
    """The voxels of ``labels`` (those where ``which`` (M,) bool is set, if given)."""
    index = labels.voxel_index if which is None else labels.voxel_index[which]
    return {tuple(v) for v in index.tolist()}


def voxel_poses(labels: VoxelLabels, only: set | None, rng) -> list[np.ndarray]:
    """For each voxel of ``labels`` (those in ``only``, if given): the grasp it teaches
    (`voxel_grasp`: one of its rotation targets drawn uniformly, at the voxel's centre)."""
    return [
        voxel_grasp(index, labels.rotations[v], labels.mask[v], rng)
        for v, index in enumerate(labels.voxel_index.tolist())
        if only is None or tuple(index) in only
    ]


def label_sets(scenes: list[Scene], args, rng) -> dict[str, Any]:
    """Per label set: density and grasp trials at its voxels (all, and those it adds)."""
    out: dict[str, Any] = {}
    today_count = sum(len(s.labels[TODAY].voxel_index) for s in scenes)
    for name in scenes[0].labels:
        counts = np.array([len(s.labels[name].voxel_index) for s in scenes])
        groups = {"all voxels": [], "voxels it adds": []} if name != TODAY else {"all voxels": []}
        for k, scene in enumerate(scenes):
            groups["all voxels"] += [(k, T) for T in voxel_poses(scene.labels[name], None, rng)]
            if name != TODAY:
                own = scene.today.grasps["T_world_tcp"][scene.today.survivors]
                added = voxel_keys(
                    scene.labels[name], added_voxels(scene.labels[name].voxel_index, own)
                )
                groups["voxels it adds"] += [
                    (k, T) for T in voxel_poses(scene.labels[name], added, rng)
                ]
        out[name] = {
            "valid_voxels_per_scene": round(float(counts.mean()), 1),
            "times_today": round(float(counts.sum() / max(today_count, 1)), 2),
            "valid_share_of_grid_pct": round(100 * float(counts.mean()) / RESOLUTION**3, 3),
            "rotation_targets_per_scene": round(
                float(np.mean([s.labels[name].mask.sum() for s in scenes])), 1
            ),
            "seconds_per_scene": round(float(np.mean([s.seconds[name] for s in scenes])), 3),
            **{group: trials(scenes, items, args.trials, f"{name}: {group}", rng)
               for group, items in groups.items()},
        }  # fmt: skip
    grasps = [
        (k, T)
        for k, s in enumerate(scenes)
        for T in s.today.grasps["T_world_tcp"][s.today.survivors]
    ]
    out[TODAY]["grasps at their TCP"] = trials(scenes, grasps, args.trials, "grasps", rng)
    return out


def trials(scenes: list[Scene], items: list, n: int, desc: str, rng) -> dict[str, Any]:
    """Trials of ``n`` of ``items`` ((scene, pose) pairs) drawn without replacement."""
    pick = rng.permutation(len(items))[:n]
    held = sum(scenes[items[i][0]].holds(items[i][1]) for i in tqdm(pick, desc=desc))
    return rate(held, len(pick))


def chebyshev(v: np.ndarray, valid: np.ndarray) -> int:
    """Chebyshev distance [voxels] from voxel ``v`` to the nearest of ``valid`` (M, 3)."""
    if not len(valid):
        return RESOLUTION
    return int(np.abs(valid - v).max(axis=1).min())


def candidate(scene: Scene, voxel: np.ndarray, hand, cfg) -> np.ndarray | None:
    """The scene's database grasp nearest to ``voxel``'s centre whose open hand, moved there
    with its rotation, passes the collision check (None: none of the `NEAREST`)."""
    T = scene.today.grasps["T_world_tcp"]
    centre = voxel_centre(voxel)
    order = np.argsort(np.linalg.norm(T[:, :3, 3] - centre, axis=1))[:NEAREST]
    moved = T[order].copy()
    moved[:, :3, 3] = centre
    free = np.flatnonzero(~scene.collides(moved, hand, cfg))
    return moved[free[0]] if len(free) else None


def false_negatives(scenes: list[Scene], hand, cfg, args, rng) -> dict[str, Any]:
    """Today's invalid near-surface voxels where the nearest free database grasp, moved to
    the voxel's centre, holds; by distance, by a tried grasp, and per label set."""
    trees = [cKDTree(s.today.grasps["points"]) for s in scenes]
    distance = [
        tree.query(voxel_centre(s.labels[TODAY].voxel_index))[0]
        for s, tree in zip(scenes, trees, strict=True)
    ]
    distance = np.concatenate([np.zeros(0), *distance])
    band = float(np.quantile(distance, SURFACE_QUANTILE)) if len(distance) else 0.0
    centres = voxel_centre(GRID)
    pool = []  # (scene, voxel) of today's invalid near-surface voxels
    for k, (scene, tree) in enumerate(zip(scenes, trees, strict=True)):
        near = (tree.query(centres)[0] <= band) & (centres[:, 2] > TABLE_HEIGHT)
        valid = voxel_keys(scene.labels[TODAY])
        pool += [(k, v) for v in GRID[near] if tuple(v.tolist()) not in valid]
    rows = []
    for i in tqdm(rng.permutation(len(pool))[: args.negatives], desc="false negatives"):
        k, v = pool[i]
        scene = scenes[k]
        pose = candidate(scene, v, hand, cfg)
        tried = voxel_of(scene.today.grasps["T_world_tcp"][:, :3, 3])
        rows.append({
            "candidate": pose is not None,
            "held": bool(pose is not None and scene.holds(pose)),
            "tried": bool(np.all(tried == v, axis=1).any()),
            "labelled_by": [n for n, lab in scene.labels.items() if tuple(v.tolist()) in voxel_keys(lab)],
            "distance": {n: chebyshev(v, lab.voxel_index) for n, lab in scene.labels.items()},
        })  # fmt: skip

    def share(selected: list[dict]) -> dict[str, Any]:
        return {**rate(sum(r["held"] for r in selected), len(selected)),
                "with_candidate": sum(r["candidate"] for r in selected)}  # fmt: skip

    per_set = {}
    for name in scenes[0].labels:
        left = [r for r in rows if name not in r["labelled_by"]]
        per_set[name] = {
            "left_invalid": share(left),
            "by_distance_to_a_valid_voxel": {
                d: share([r for r in left if lo <= r["distance"][name] <= hi])
                for d, lo, hi in DISTANCES
            },
            "holding_voxels_it_labels": sum(r["held"] and name in r["labelled_by"] for r in rows),
        }
    return {
        "band_m": round(band, 4),
        "near_surface_invalid_voxels_per_scene": round(len(pool) / len(scenes), 1),
        "tried": share([r for r in rows if r["tried"]]),
        "untried": share([r for r in rows if not r["tried"]]),
        "per_label_set": per_set,
    }


def measure(objects: str, hand: GripperSpec, args: argparse.Namespace) -> dict[str, Any]:
    cfg = SceneConfig(
        object_set=objects,
        gripper=hand.name,
        pool_size=args.pool,
        database=DatabaseConfig(
            grasps=args.grasps, directions=args.directions, offset=tuple(args.offset)
        ),
    )
    pool = scene_pool(cfg)
    largest = DatabaseConfig(
        grasps=max(args.grasps, args.more_grasps),
        directions=args.directions,
        offset=tuple(args.offset),
    )
    built = [
        cached_database(obj, hand, args.cache, largest, seed=k)
        for k, obj in enumerate(tqdm(pool.objects, desc=f"{objects} databases", unit="object"))
    ]
    databases = {TODAY: [prefix(db, args.grasps) for db in built], "more": built}
    more = f"{args.more_grasps} grasps" if args.more_grasps > args.grasps else None
    rng = np.random.default_rng(0)

    def scenes(ids: range, spreads: list) -> list[Scene]:
        return [build_scene(i, cfg, spreads, hand, pool, databases, more if spreads else None)
                for i in tqdm(ids, "scenes")]  # fmt: skip

    shifts = tolerance(scenes(range(args.tolerance_scenes), []), hand, cfg, args, rng)
    evaluation = scenes(range(EVALUATION_SCENE, EVALUATION_SCENE + args.scenes), args.spreads)
    return {
        "objects": objects,
        "tolerance": shifts,
        "surviving_grasps_per_scene": round(
            float(np.mean([s.today.survivors.sum() for s in evaluation])), 1
        ),
        "label_sets": label_sets(evaluation, args, rng),
        "false_negatives": false_negatives(evaluation, hand, cfg, args, rng),
    }


def pct(r: dict[str, Any]) -> str:
    if not r["trials"]:
        return "–"
    lo, hi = r["ci95"]
    return f"{r['pct']:.0f} [{lo:.0f}, {hi:.0f}] ({r['trials']})"


def table(cells: list[dict[str, Any]], args: argparse.Namespace) -> str:
    sets = [c["objects"] for c in cells]
    head = "| " + " | ".join(sets) + " |"
    rule = "|---" * len(sets) + "|"
    lines = ["Tolerance: success % [Wilson 95 %] (trials) of surviving grasps moved by whole "
             "voxels (7.5 mm) along their own axes, and how many moves the collision check "
             "lets through.", "", "| axis | move " + head, "|---|---" + rule,
             "| – | 0 | " + " | ".join(pct(c["tolerance"]["unmoved +0"]) for c in cells) + " |"]  # fmt: skip
    for axis in AXES:
        for s in [s for s in range(-args.max_shift, args.max_shift + 1) if s]:
            entries = [c["tolerance"][f"{axis} {s:+d}"] for c in cells]
            lines.append(f"| {axis} | {s:+d} | " + " | ".join(
                f"{pct(e)}; {e['free']}/{e['moved']} free" for e in entries) + " |")  # fmt: skip
    for c in cells:
        lines += ["", f"{c['objects']}: label sets ({c['surviving_grasps_per_scene']} surviving "
                  "grasps per scene); success % [Wilson 95 %] (trials) at the TCP of the voxel's "
                  "centre; false negatives: today's invalid near-surface voxels holding a grasp, "
                  "among those the set still leaves invalid.", "",
                  "| label set | valid voxels per scene (× today) | rotation targets per scene "
                  "| s per scene | success: all voxels | success: voxels it adds "
                  "| false negatives left | … 1 voxel from its valid voxels | … 2 | … 3 or more |",
                  "|---|---|---|---|---|---|---|---|---|---|"]  # fmt: skip
        for name, s in c["label_sets"].items():
            fn = c["false_negatives"]["per_label_set"][name]
            by = fn["by_distance_to_a_valid_voxel"]
            lines.append(
                f"| {name} | {s['valid_voxels_per_scene']} (×{s['times_today']}) "
                f"| {s['rotation_targets_per_scene']} | {s['seconds_per_scene']} "
                f"| {pct(s['all voxels'])} | {pct(s['voxels it adds']) if 'voxels it adds' in s else '–'} "
                f"| {pct(fn['left_invalid'])} | " + " | ".join(pct(by[d]) for d, _, _ in DISTANCES) + " |"
            )  # fmt: skip
        f = c["false_negatives"]
        lines += ["", f"Today's surviving grasps at their own TCP: "
                  f"{pct(c['label_sets'][TODAY]['grasps at their TCP'])}. Near-surface band "
                  f"{1000 * f['band_m']:.1f} mm, {f['near_surface_invalid_voxels_per_scene']} invalid "
                  f"voxels per scene in it; holding a grasp where a database grasp was tried in "
                  f"the voxel (all collide): {pct(f['tried'])}, where none was: {pct(f['untried'])}."]  # fmt: skip
    return "\n".join(lines) + "\n"


def spread_arg(text: str) -> tuple[float, ...]:
    values = tuple(float(x) for x in text.split(","))
    if len(values) != 4 or min(values) < 0:
        raise argparse.ArgumentTypeError(f"a spread is BACK,FORWARD,E_Y,E_Z ≥ 0, got {text!r}")
    return values


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--objects", nargs="+", default=["vgn-pile-train", "household-train"],
                        help="training object sets, one cell each (default: %(default)s)")  # fmt: skip
    parser.add_argument("--gripper", default="robotiq-2f85", help="the hand (default: %(default)s)")
    parser.add_argument(
        "--pool", type=int, default=12, help="objects per set (default: %(default)s)"
    )
    parser.add_argument("--grasps", type=int, default=150,
                        help="held grasps per database today, as VGN's datasets (default: %(default)s)")  # fmt: skip
    parser.add_argument("--more-grasps", type=int, default=300,
                        help="a larger database to compare (0: none) (default: %(default)s)")  # fmt: skip
    parser.add_argument("--directions", type=int, default=4,
                        help="score directions per database; no score is measured here "
                        "(default: %(default)s)")  # fmt: skip
    parser.add_argument("--offset", type=float, nargs=2, metavar=("LO", "HI"),
                        default=DatabaseConfig.offset,
                        help="range [m] of the databases' TCP offset along the approach from the "
                        "contacts' midpoint (DatabaseConfig.offset; default: %(default)s; the "
                        "final campaign's wide Robotiq data: -0.03 0.03)")  # fmt: skip
    parser.add_argument("--cache", default="out/label_density/db", type=Path,
                        help="folder of the cached grasp databases (default: %(default)s)")  # fmt: skip
    parser.add_argument("--tolerance-scenes", type=int, default=30,
                        help="scenes of the tolerance measurement (default: %(default)s)")  # fmt: skip
    parser.add_argument("--tolerance-grasps", type=int, default=6,
                        help="surviving grasps moved per scene (default: %(default)s)")  # fmt: skip
    parser.add_argument("--max-shift", type=int, default=3,
                        help="largest move [voxels] along each axis (default: %(default)s)")  # fmt: skip
    parser.add_argument("--scenes", type=int, default=40,
                        help="scenes of the label sets and false negatives (default: %(default)s)")  # fmt: skip
    parser.add_argument("--spreads", nargs="+", type=spread_arg,
                        default=[(1.0, 2.0, 1.0, 1.0), (1.0, 1.0, 1.0, 1.0), (2.0, 3.0, 1.0, 1.0),
                                 (1.0, 2.0, 2.0, 2.0), (2.0, 3.0, 2.0, 2.0)],
                        metavar="BACK,FORWARD,E_Y,E_Z",
                        help="spreads compared [voxels of 7.5 mm]: back and forward along e_x, "
                        "either way along e_y and e_z; the first is also measured with the larger "
                        "databases (default: 1,2,1,1 1,1,1,1 2,3,1,1 1,2,2,2 2,3,2,2)")  # fmt: skip
    parser.add_argument("--trials", type=int, default=200,
                        help="grasp trials per group of labels (default: %(default)s)")  # fmt: skip
    parser.add_argument("--negatives", type=int, default=500,
                        help="invalid near-surface voxels tried (default: %(default)s)")  # fmt: skip
    add_result_option(parser, "label_density")
    args = parse_args(
        parser,
        outputs=("result", "cache"),
        quick={"objects": ["household-train"], "pool": 2, "grasps": 6, "more_grasps": 8,
               "tolerance_scenes": 2, "tolerance_grasps": 1, "max_shift": 1, "scenes": 2,
               "spreads": [(1.0, 2.0, 1.0, 1.0)], "trials": 2, "negatives": 3},
    )  # fmt: skip
    torch.set_num_threads(1)
    hand = get_gripper(args.gripper)
    cells = [measure(objects, hand, args) for objects in args.objects]
    text = table(cells, args)
    print(text)
    write_result(
        args.result,
        "label density, label physics and false negatives of the validity labels",
        command_line("SYMGRASP_DATA=../shared PYTHONPATH=src"),
        cells,
        text,
        gripper=args.gripper,
        offset_m=list(args.offset),
        spreads_voxels=args.spreads,
        sizes={k: getattr(args, k) for k in ("pool", "grasps", "more_grasps", "directions",
               "tolerance_scenes", "tolerance_grasps", "max_shift", "scenes", "trials",
               "negatives")},
    )  # fmt: skip


if __name__ == "__main__":
    run_main(main)
