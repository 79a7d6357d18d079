"""``symgrasp data inspect`` and ``show``: the dataset card and pictures of one scene."""

from __future__ import annotations

import dataclasses
import hashlib
import json
import zipfile
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from symgrasp.atomic import write_atomic
from symgrasp.data.dataset import (
    GraspDataset,
    ManifestMismatch,
    check_scene_file,
    dataset_hash,
    load_scene,
    read_manifest,
    scene_path,
)
from symgrasp.data.generate import DATASET, config_from_dict
from symgrasp.data.grasp_db import database_path, read_cached
from symgrasp.data.scenes import DEPTH_UNIT, scene_pool
from symgrasp.data.validate import validate_labels
from symgrasp.folders import writes_folder
from symgrasp.objects.folder import MissingData
from symgrasp.sim.grippers import GripperSpec
from symgrasp.workspace import RESOLUTION, VOXEL_SIZE, WORKSPACE_SIZE

SCORE_BINS = np.linspace(0.0, 1.0, 11)

VALIDATION_NOTE = (
    "labelled: the grasps the network is taught, one valid voxel drawn uniformly among the "
    "scene files' (with its label spread, if any), the TCP at the voxel's centre, one of its "
    "rotation targets; random: a random surface point and rotation in the same scene. Without "
    "a spread the valid voxels are those of the surviving grasps, so this differs from cards "
    "made before the voxels were checked (each grasp at its own TCP) only by the TCP's move to "
    "its voxel's centre, at most 3.75 mm per axis. added: the trials at voxels holding no "
    "stored grasp's TCP (the ones a spread adds). Rates are fractions, intervals Wilson 95 %."
)
"""What the card's ``label_validation`` numbers are (`symgrasp.data.validate`)."""

COVERAGE_NOTE = (
    "per object family (a procedural family, or a mesh object's own name): how often its "
    "objects lie in the scenes (placements) and the mean share "
    "of an object's held database grasps that survive its scene's collision check (kept_share): "
    "the labels a family's objects get, least covered first; a family near 0 is one the network "
    "is taught almost no grasp on."
)
"""What the card's ``label_coverage`` numbers are."""

COVERAGE_SHOWN = 12
"""Families of the least label coverage drawn on the card's picture."""

SHOWN = 10
"""The mismatches ``data inspect``'s one error line names (`manifest_mismatches`); it counts
the rest."""


def manifest_mismatches(root: str | Path) -> list[str]:
    """What ``root``'s files break of its manifest's promises, one line each naming the file:
    a scene file missing, one on disk that the manifest does not list, two scene files with
    the same bytes, one that is not the scene its name says or breaks the contract's shapes
    (`check_scene_file`), and the dataset hash (`dataset_hash`, over every file's bytes) when
    it differs from the recorded one. Empty for a dataset as generated. `GraspDataset` refuses
    the first of these it meets; this lists them all (≈ 0.6 ms per scene, 5 s for 8 000)."""
    root = Path(root)
    manifest = read_manifest(root / "manifest.json")
    listed = manifest["scene_ids"]
    on_disk = {p.name for p in (root / "scenes").glob("scene_*.npz")}
    problems = [
        f"{root / 'scenes' / name}: not in the manifest"
        for name in sorted(on_disk - {scene_path(root, i).name for i in listed})
    ]
    seen: dict[bytes, Path] = {}
    for scene_id in listed:
        path = scene_path(root, scene_id)
        if not path.is_file():
            problems.append(f"{path}: missing")
            continue
        digest = hashlib.sha256(path.read_bytes()).digest()
        if digest in seen:
            problems.append(f"{path}: the same bytes as {seen[digest]}")
        seen.setdefault(digest, path)
        try:
            with zipfile.ZipFile(path) as z:
                check_scene_file(z, path, scene_id, manifest["k_max"])
        except (OSError, ValueError, zipfile.BadZipFile) as err:
            problems.append(str(err) if str(path) in str(err) else f"{path}: {err}")
    recorded = manifest.get("dataset_hash")
    if recorded and not any(p.endswith(": missing") for p in problems):
        actual = dataset_hash(root, listed)
        if actual != recorded:
            problems.append(
                f"{root / 'manifest.json'}: dataset hash {recorded} recorded, {actual} on disk "
                "(a scene file changed since it was generated)"
            )
    return problems


@writes_folder(DATASET, "root")
def dataset_card(root: str | Path, validate: int = 0, seed: int = 0) -> dict[str, Any]:
    """Counts, class balance and histograms of a dataset, and the depth noise its images were
    made with (``noise``); written to ``card.json`` and ``card.png`` in ``root``, which is held
    for the call (one writer at a time: not while `generate` writes it, `symgrasp.folders`).
    ``validate`` > 0 adds that many physics trials of the labelled voxels' grasps against
    random grasps (`validate_labels`, ``label_validation``: `VALIDATION_NOTE`).
    ValueError naming the first `SHOWN` of `manifest_mismatches` on one line when the folder is
    not what its manifest promises."""
    root = Path(root)
    try:  # refuses an unfinished dataset in its own words; a mismatch: all of them below
        data = GraspDataset(root, split="all")
    except ManifestMismatch:
        data = None
    problems = manifest_mismatches(root)
    if problems or data is None:
        more = f"; and {len(problems) - SHOWN} more" if len(problems) > SHOWN else ""
        raise ValueError(
            f"{root} does not match its manifest ({len(problems)} mismatches): "
            + "; ".join(problems[:SHOWN])
            + more
        )
    per_scene: dict[str, list[float]] = {
        k: [] for k in ("objects", "grasps_total", "grasps_kept", "valid_voxels", "targets")
    }
    scores, targets, kinds = [], [], []
    kept_per_object: list[tuple[np.ndarray, np.ndarray]] = []  # (pool indices, kept grasps)
    dropped = 0
    for path in data.paths:
        r = load_scene(path)
        placed = r["object_pool_index"]
        kept_per_object.append((placed, np.bincount(r["grasp_object"], minlength=len(placed))))
        per_scene["objects"].append(len(r["object_pool_index"]))
        per_scene["grasps_total"].append(int(r["grasps_total"]))
        per_scene["grasps_kept"].append(len(r["grasp_pose"]))
        per_scene["valid_voxels"].append(len(r["voxel_index"]))
        per_scene["targets"].append(int(r["voxel_rotation_mask"].sum()))
        scores.append(r["voxel_score"])
        targets.append(r["voxel_rotation_mask"].sum(axis=1))
        kinds.append(str(r["kind"]))
        dropped += int(r["rotations_dropped"])
    score = np.concatenate(scores) if scores else np.zeros(0)
    per_voxel = np.concatenate(targets) if targets else np.zeros(0, dtype=int)
    valid = np.asarray(per_scene["valid_voxels"])
    config = data.manifest.get("config", {})
    card: dict[str, Any] = {
        "root": str(root),
        "manifest": {k: v for k, v in data.manifest.items() if k not in ("scene_ids", "config")},
        "scenes": len(data),
        "noise": config.get("noise", "none"),  # older manifests: none
        "table_scale": config.get("table_scale", False),
        "skipped_files": [str(p) for p in data.skipped],
        "scene_kinds": {k: kinds.count(k) for k in sorted(set(kinds))},
        "mean_per_scene": {k: float(np.mean(v)) if v else 0.0 for k, v in per_scene.items()},
        "grasp_survival_rate": float(
            np.sum(per_scene["grasps_kept"]) / max(1, np.sum(per_scene["grasps_total"]))
        ),
        "valid_voxel_fraction": float(valid.mean() / RESOLUTION**3) if len(valid) else 0.0,
        "score_histogram": {
            "bins": SCORE_BINS.tolist(),
            "counts": np.histogram(score, SCORE_BINS)[0].tolist(),
            "mean": float(score.mean()) if len(score) else 0.0,
        },
        "targets_per_voxel": {
            str(k): int(np.sum(per_voxel == k)) for k in range(1, data.k_max + 1)
        },
        "rotations_dropped_beyond_k_max": dropped,
    }
    cfg = config_from_dict(config, root / "manifest.json") if config else None
    card["label_coverage"] = label_coverage(root, cfg, data.gripper, kept_per_object)
    if validate > 0 and len(data):
        ids = [int(p.stem.split("_")[1]) for p in data.paths]
        result = validate_labels(root, cfg, data.gripper, ids, validate, seed)
        card["label_validation"] = {**dataclasses.asdict(result), "about": VALIDATION_NOTE}
    write_atomic(root / "card.json", lambda f: json.dump(card, f, indent=1), mode="w")

    fig, ax = plt.subplots(1, 4, figsize=(17, 3.6))
    ax[0].hist(valid, bins=20)
    ax[0].set(xlabel="valid voxels per scene", ylabel="scenes")
    ax[1].hist(score, SCORE_BINS)
    ax[1].set(xlabel="gravity-rejection score (valid voxels)", ylabel="voxels")
    ax[2].bar(
        range(1, data.k_max + 1),
        [card["targets_per_voxel"][str(k)] for k in range(1, data.k_max + 1)],
    )
    ax[2].set(xlabel="rotation targets per voxel", ylabel="voxels")
    coverage = list(card["label_coverage"].get("families", {}).items())[:COVERAGE_SHOWN]
    if coverage:
        ax[3].barh(
            [f for f, _ in coverage][::-1], [100 * c["kept_share"] for _, c in coverage][::-1]
        )
        ax[3].set(
            xlabel="% of its database grasps kept in its scenes", title="least covered families"
        )
    else:
        ax[3].set_axis_off()
    fig.suptitle(
        f"{root.name}: {len(data)} scenes, {data.gripper.name}, {data.object_set}, "
        f"depth noise {card['noise']}{', table-scaled' if card['table_scale'] else ''}"
    )
    fig.tight_layout()
    fig.savefig(root / "card.png", dpi=100)
    plt.close(fig)
    return card


def label_coverage(
    root: Path,
    cfg: Any,
    gripper: GripperSpec,
    kept_per_object: list[tuple[np.ndarray, np.ndarray]],
) -> dict[str, Any]:
    """The card's ``label_coverage`` (`COVERAGE_NOTE`): per object family of the dataset's pool,
    its placements in the scenes and the mean share of an object's held grasps (its database
    in ``root/db``) that its scene kept. ``kept_per_object``: per scene, the pool index of
    each object and how many of its grasps survived. Without the object set (its meshes not
    in the data folder) or a manifest's configuration, the reason instead of the families."""
    if cfg is None:
        return {"unavailable": "the manifest records no configuration", "about": COVERAGE_NOTE}
    try:
        pool = scene_pool(cfg)
    except MissingData as err:
        return {"unavailable": str(err), "about": COVERAGE_NOTE}
    held = np.zeros(len(pool.objects))
    for k, obj in enumerate(pool.objects):
        db = read_cached(database_path(root / "db", obj, gripper, cfg.database, k))
        held[k] = np.nan if db is None else db.held.sum()
    shares: dict[str, list[float]] = {}
    for placed, kept in kept_per_object:
        for k, n in zip(placed, kept, strict=True):
            if held[k] > 0:
                shares.setdefault(pool.objects[k].family, []).append(n / held[k])
    order = sorted(shares, key=lambda f: (np.mean(shares[f]), f))
    families = {f: {"placements": len(shares[f]), "kept_share": float(np.mean(shares[f]))}
                for f in order}  # fmt: skip
    return {"families": families, "about": COVERAGE_NOTE}


def show_scene(root: str | Path, scene_id: int, out: str | Path | None = None) -> Path:
    """Draw scene ``scene_id``: TSDF surface voxels and labelled grasps (TCP and approach,
    coloured by score), and the depth image. Returns the picture's path."""
    r = load_scene(scene_path(root, scene_id))
    out = Path(out) if out else Path(root) / f"scene_{scene_id:06d}.png"
    fig = plt.figure(figsize=(12, 5))
    ax = fig.add_subplot(1, 2, 1, projection="3d")
    tsdf = r["tsdf"].astype(np.float32)
    surface = np.argwhere(np.abs(tsdf) < 0.3)
    centres = (surface + 0.5) * VOXEL_SIZE
    ax.scatter(*centres.T, s=1, c="0.6", alpha=0.3)
    pose, score = r["grasp_pose"], r["grasp_score"]
    if len(pose):
        tcp, approach = pose[:, :3, 3], pose[:, :3, 0]
        ax.quiver(*(tcp - 0.02 * approach).T, *(0.02 * approach).T, color=plt.cm.viridis(score))
        ax.scatter(*tcp.T, s=4, c=score, cmap="viridis", vmin=0, vmax=1)
    limits = (0, WORKSPACE_SIZE)
    ax.set(xlim=limits, ylim=limits, zlim=limits, xlabel="x", ylabel="y", zlabel="z")
    ax.set_title(f"scene {scene_id} ({r['kind']}): {len(r['voxel_index'])} valid voxels")
    ax2 = fig.add_subplot(1, 2, 2)
    ax2.imshow(r["depth"] * DEPTH_UNIT, cmap="gray")
    ax2.set_title("depth [m]")
    ax2.axis("off")
    fig.tight_layout()
    write_atomic(out, lambda file: fig.savefig(file, format="png", dpi=100))
    plt.close(fig)
    return out
