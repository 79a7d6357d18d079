"""``symgrasp data relabel``: a dataset's scenes with other voxel labels, without simulating
them again.

A scene file keeps its surviving grasps (``grasp_pose``, ``grasp_score``, ``grasp_width``), its
objects (``object_pool_index``, ``object_poses``) and its id, and labelling draws nothing from
the scene's random stream that the observation needs: the same scene generated with another
``--label-spread`` has the same objects, grasps, camera, depth image and TSDF, and differs only
in its voxel labels. `relabel` writes that dataset from a finished one in milliseconds (no
spread: `symgrasp.data.labels.voxelise` of the grasps) or a fraction of a second (a spread:
`symgrasp.data.scenes.spread_labels`, its collision checks against the scene's surface samples,
drawn again from the scene's stream as generation drew them, `scene_draws` and `scene_points`)
per scene instead of the scene's physics (≈ 1 s): an ablation of the labels on the very same
scenes at the cost of one dataset.

The labels come from the grasps as stored, in float32, where generation labelled them in
float64: a grasp whose TCP lies within float32 rounding (≈ 3e-8 m) of a voxel face, two scores
equal in float32 but not in float64, or two rotations 5° apart to within rounding can be
labelled otherwise (docs/data.md, "Relabelled datasets", measures how often). The manifest is
the one generation writes for the configuration with the new spread, plus ``derived_from``: the
source folder, its dataset hash and spread, and this run's versions. The grasp databases are
linked (copied where links fail) into ``db/``, so that the folder is a whole dataset.
"""

from __future__ import annotations

import dataclasses
import json
import os
import shutil
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from symgrasp.atomic import check_json, read_json, write_atomic
from symgrasp.config import SceneConfig
from symgrasp.data.dataset import load_scene, read_manifest, scene_path
from symgrasp.data.generate import DATASET, config_from_dict, dataset_manifest, scenes_to_write
from symgrasp.data.labels import voxelise
from symgrasp.data.scenes import (
    ScenePool,
    label_arrays,
    scene_draws,
    scene_points,
    scene_pool,
    spread_labels,
)
from symgrasp.folders import writes_folder
from symgrasp.parallel.base import versions
from symgrasp.sim.collision import hand_collides
from symgrasp.sim.grippers import GripperSpec, get_gripper

NO_SPREAD = (0.0, 0.0, 0.0, 0.0)


def relabelled(
    record: dict[str, np.ndarray],
    cfg: SceneConfig,
    hand: GripperSpec | None = None,
    pool: ScenePool | None = None,
    seed: int = 0,
) -> dict[str, np.ndarray]:
    """The scene file's arrays ``record`` with the voxel labels of ``cfg`` (its
    ``label_spread`` and ``k_max``) made from its surviving grasps; the other arrays as they
    are, in the same order. A spread needs the ``hand``, the dataset's ``pool`` and ``seed``:
    its collision checks test the scene's surface samples, drawn again."""
    poses = record["grasp_pose"].astype(np.float64)
    if not any(cfg.label_spread):
        labels = voxelise(poses, record["grasp_score"], record["grasp_width"], cfg.k_max)
        return {**record, **label_arrays(labels)}
    rng = scene_draws(int(record["scene_id"]), cfg, seed)[0]
    objects = [pool.objects[k] for k in record["object_pool_index"]]
    points = scene_points(objects, record["object_poses"], cfg, rng)
    labels = spread_labels(
        poses, record["grasp_score"], record["grasp_width"], cfg,
        lambda T: hand_collides(T, hand, points, tolerance=-cfg.clearance),
    )  # fmt: skip
    return {**record, **label_arrays(labels)}


def _source(src: Path, spread: tuple[float, ...]) -> dict[str, Any]:
    """The manifest of the finished dataset ``src``, whose labels are not already those of
    ``spread``; ValueError naming ``src`` otherwise."""
    path = src / "manifest.json"
    if not path.is_file():
        raise ValueError(f"src must be a dataset folder with manifest.json, got {src}")
    manifest = read_manifest(path)
    if "config" in manifest and config_from_dict(manifest["config"], path).label_spread == spread:
        what = (
            "a label spread of " + " ".join(f"{v:g}" for v in spread)
            if any(spread)
            else "no label spread"
        )
        raise ValueError(f"src {src} already has {what}: nothing to relabel")
    on_disk = len(list((src / "scenes").glob("scene_*.npz")))
    if manifest.get("failed") or not manifest["scene_ids"] or on_disk > len(manifest["scene_ids"]):
        raise ValueError(
            f"src {src} is an unfinished dataset ({on_disk} scene files, "
            f"{len(manifest['scene_ids'])} in its manifest); finish it with "
            "`symgrasp data generate ... --resume` first"
        )
    check_json(manifest, path, "dataset manifest", dict, ("config", "seed", "gripper"))
    return manifest


@writes_folder(DATASET)
def relabel(
    src: str | Path,
    out: str | Path,
    resume: bool = False,
    label_spread: tuple[float, float, float, float] = NO_SPREAD,
) -> dict[str, Any]:
    """Write to ``out`` the scenes of the finished dataset ``src`` with the labels of
    ``label_spread`` [m] (`SceneConfig.label_spread`: back, forward, e_y, e_z; default none,
    each grasp at its TCP's voxel alone; module doc); returns the manifest. ``resume``
    continues an interrupted run, skipping the scenes written.

    Raises:
        ValueError: ``src`` is not a finished dataset or already has these labels;
            ``label_spread`` is not a valid spread; ``out`` is ``src``, holds files that are
            not a dataset, or holds a dataset (without ``resume``, or one not relabelled from
            ``src`` as it is now).
    """
    src, root = Path(src), Path(out)
    if root.resolve() == src.resolve():
        raise ValueError(f"out must be another folder than src, got {out}")
    spread = tuple(float(v) for v in label_spread)
    source = _source(src, spread)
    cfg = dataclasses.replace(config_from_dict(source["config"]), label_spread=spread)
    hand = get_gripper(source["gripper"])
    pool = scene_pool(cfg) if any(spread) else None
    derived = {
        "dataset": str(src.resolve()),
        "dataset_hash": source.get("dataset_hash"),
        "label_spread": source["config"]["label_spread"],
        "versions": versions(),
    }
    manifest_path = root / "manifest.json"
    if manifest_path.exists():
        old = read_json(manifest_path, "dataset manifest", dict, ())
        if not resume:
            raise ValueError(f"out {root} already holds a dataset; pass resume=True (--resume)")
        was = old.get("derived_from", {})
        if (was.get("dataset"), was.get("dataset_hash")) != (
            derived["dataset"],
            derived["dataset_hash"],
        ):
            raise ValueError(
                f"out {root} holds a dataset not relabelled from {src} as it is now (derived "
                f"from {was.get('dataset')!r}, hash {was.get('dataset_hash')!r}); choose "
                "another out (--out)"
            )

    def manifest(ids: list[int]) -> dict[str, Any]:
        made = dataset_manifest(cfg, hand, source["seed"], ids, root, source["generated_with"])
        return {**made, "derived_from": derived}

    ids = source["scene_ids"]
    write_atomic(manifest_path, lambda f: json.dump(manifest([]), f, indent=1), mode="w")
    _link_databases(src / "db", root / "db")
    for i in tqdm(scenes_to_write(root, ids, resume), desc="relabel", unit="scene"):
        record = relabelled(load_scene(scene_path(src, i)), cfg, hand, pool, source["seed"])
        write_atomic(scene_path(root, i), lambda f, r=record: np.savez_compressed(f, **r))
    done = manifest(ids)
    write_atomic(manifest_path, lambda f: json.dump(done, f, indent=1), mode="w")
    return done


def _link_databases(src: Path, dst: Path) -> None:
    """Hard-link (copy where that fails) every database file of ``src`` missing in ``dst``."""
    dst.mkdir(parents=True, exist_ok=True)
    for path in sorted(src.glob("*.npz")):
        target = dst / path.name
        if not target.exists():
            try:
                os.link(path, target)
            except OSError:
                shutil.copy2(path, target)
