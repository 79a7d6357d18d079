"""``symgrasp data generate``: databases, then scenes, into a resumable dataset folder.

Layout of a dataset folder::

    manifest.json          configuration, the gripper's whole spec, scene ids, hash, version
                           (written atomically)
    db/<object>_<gripper>_<key>.npz   per-object grasp databases (cache, reusable)
    scenes/scene_000123.npz           one compressed shard per scene

Work is split into pure tasks — one per missing object database, one per scene id — that an
executor (`symgrasp.parallel`: this process, local processes or a Ray cluster) runs. The
gripper is resolved once, here, and handed to the workers; each worker resolves the object set
and its pool once, in its setup (`symgrasp.data.scenes.scene_pool`). Each task returns what it
made and this process writes it, to a temporary name renamed into place, so the folder is
the same bytes on every backend, an interrupted run loses only the scenes in flight, and
``resume=True`` skips the scenes already on disk. A scene whose task raises is recorded in the
manifest (``failed``: its id, seed, error and traceback) and the others are written;
`generate` then raises `TasksFailed`, and a resumed run tries it again. The process holds the
folder for the run (`symgrasp.folders`): a second run into it is refused, not mixed in.
"""

from __future__ import annotations

import dataclasses
import io
import json
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

import symgrasp
from symgrasp.atomic import read_json, write_atomic
from symgrasp.config import SEED_MAX, DatabaseConfig, ParallelConfig, SceneConfig, check_range
from symgrasp.data.dataset import dataset_hash, load_scene, scene_path
from symgrasp.data.grasp_db import GraspDatabase, build_database, database_path, read_cached
from symgrasp.data.scenes import ScenePool, make_scene_record, scene_pool
from symgrasp.folders import Outputs, writes_folder
from symgrasp.objects.sets import unrecorded_decomposition
from symgrasp.parallel import Executor, Failure, Job, TasksFailed, open_executor, torch_threads
from symgrasp.parallel.base import versions
from symgrasp.sim.grippers import GripperSpec, get_gripper
from symgrasp.workspace import RESOLUTION, VOXEL_SIZE


def _as_made(config: dict[str, Any]) -> dict[str, Any]:
    """A manifest's ``config`` with the decomposition its scenes were made with where it
    predates the field (`symgrasp.objects.sets.unrecorded_decomposition`); the other fields it
    predates read as their defaults, which it was made with."""
    objects = config.get("object_set", SceneConfig.object_set)
    return {"decomposition": unrecorded_decomposition(objects), **config}


def config_from_dict(d: dict[str, Any], path: str | Path | None = None) -> SceneConfig:
    """The :class:`SceneConfig` saved in the manifest ``path`` (`_as_made`); ValueError naming
    that file and the field when ``d`` is not one (a hand-edited ``"k_max": "eight"``)."""
    try:
        d = _as_made(dict(d))
        db = d.pop("database")
        db["offset"] = tuple(db["offset"])
        for key in ("kinds", "camera_distance", "camera_polar", "label_spread"):
            if key in d:  # a manifest from before a field was added: its default
                d[key] = tuple(d[key])
        return SceneConfig(**d, database=DatabaseConfig(**db))
    except (KeyError, TypeError, ValueError) as err:
        what = f"it lacks {err}" if isinstance(err, KeyError) else err
        raise ValueError(
            f"{path or 'a manifest'} is not a valid dataset manifest: its config: {what}"
        ) from None


def dataset_manifest(
    cfg: SceneConfig,
    hand: GripperSpec,
    seed: int,
    scene_ids: list[int],
    root: Path,
    generated_with: list[dict[str, Any]],
) -> dict[str, Any]:
    """The manifest of ``root`` holding ``scene_ids`` (an empty list while generating), made
    by the runs ``generated_with`` lists for the gripper ``hand``."""
    return {
        "gripper": hand.to_dict(),
        "object_set": cfg.object_set,
        "k_max": cfg.k_max,
        "resolution": RESOLUTION,
        "voxel_size": VOXEL_SIZE,
        "num_scenes": len(scene_ids),
        "scene_ids": scene_ids,
        "seed": seed,
        "dataset_hash": dataset_hash(root, scene_ids),
        "symgrasp_version": symgrasp.__version__,
        "config": dataclasses.asdict(cfg),
        "generated_with": generated_with,
    }


# --- the pure tasks and their worker-side state -----------------------------------------

_WORKER: dict[str, Any] = {}

TASK_THREADS = 1
"""Torch threads of each task: one core per task (fusion threads would oversubscribe the
workers); the caller's own restored after each (`torch_threads`)."""


def _setup(
    cfg: SceneConfig, hand: GripperSpec, seed: int, databases: list[GraspDatabase] | None
) -> None:
    _WORKER.update(cfg=cfg, hand=hand, pool=scene_pool(cfg), seed=seed, databases=databases)


def _database_task(k: int) -> GraspDatabase:
    cfg: SceneConfig = _WORKER["cfg"]
    with torch_threads(TASK_THREADS):
        return build_database(_WORKER["pool"].objects[k], _WORKER["hand"], cfg.database, seed=k)


def _scene_task(scene_id: int) -> bytes:
    """Scene ``scene_id`` as the bytes of its compressed file (written by the caller)."""
    w = _WORKER
    with torch_threads(TASK_THREADS):
        record = make_scene_record(
            scene_id, w["cfg"], w["hand"], w["pool"], w["databases"], w["seed"]
        )
    buffer = io.BytesIO()
    np.savez_compressed(buffer, **record)
    return buffer.getvalue()


def scenes_to_write(root: Path, scene_ids: Iterable[int], resume: bool) -> list[int]:
    """The ids of ``scene_ids`` to write into the dataset ``root``: all of them, or with
    ``resume`` those whose file is missing or unreadable (each of those named on stdout)."""
    todo = []
    for i in scene_ids:
        path = scene_path(root, i)
        if resume and path.exists():
            try:
                load_scene(path)
                continue
            except ValueError as err:
                print(f"rewriting {path}: {err}")
        todo.append(i)
    return todo


def _write_bytes(path: Path, data: bytes) -> None:
    write_atomic(path, lambda f: f.write(data))


def _failure(what: str, arg: int, seed: int, failure: Failure) -> dict[str, Any]:
    """A failed task as JSON data: which ``what`` (object or scene), its seed, why."""
    return {what: arg, "seed": seed, "error": failure.error, "traceback": failure.traceback}


def _databases(
    cfg: SceneConfig, hand: GripperSpec, pool: ScenePool, db_dir: Path, executor: Executor
) -> tuple[list[GraspDatabase], list[dict[str, Any]]]:
    """The pool's databases for ``hand``, in pool order: read from ``db_dir``, the missing ones
    built by ``executor`` and written there; and the failed builds (object index ``k``, seed
    ``k``)."""
    paths = [
        database_path(db_dir, obj, hand, cfg.database, k) for k, obj in enumerate(pool.objects)
    ]
    found = [read_cached(path) for path in paths]
    missing = [k for k, db in enumerate(found) if db is None]
    failed = []
    job = Job(_database_task, _setup, (cfg, hand, 0, None))
    for k, result in executor.map(job, missing, "object databases"):
        if isinstance(result, Failure):
            failed.append(_failure("object", k, k, result))
        else:
            result.save(paths[k])
            found[k] = result
    return found, failed


MAX_SCENES = 10_000_000
"""Most scenes one dataset holds (≈ 10 GB of scene files at the default size)."""


DATASET = Outputs(
    "a symgrasp dataset",
    kinds=("db", "scenes", "card.json", "card.png", "scene_*.png"),
    record=("manifest.json",),
)
"""A dataset folder: what generate, the card and `symgrasp data show` write there; a folder
without a manifest may hold them too (a copied ``db/`` of reusable databases)."""


@writes_folder(DATASET)
def generate(
    out: str | Path,
    cfg: SceneConfig,
    scenes: int,
    seed: int = 0,
    resume: bool = False,
    parallel: ParallelConfig = ParallelConfig(),
) -> dict[str, Any]:
    """Write ``scenes`` labelled scenes (ids 0 … scenes − 1) to ``out`` with the executor
    ``parallel`` describes; returns the manifest.

    ``out`` is held for the call (`symgrasp.folders.output_folder`): one writer at a time.

    Raises:
        ValueError: ``out`` is not a folder path, holds files that are not a dataset, or is
            being written by another process; it already holds scenes and ``resume`` is
            False, or holds a dataset of another configuration or seed (the message names the
            fields that differ); or `open_executor`'s bad input.
        TasksFailed: some tasks raised (the other scenes are written).
    """
    hand = get_gripper(cfg.gripper)  # the names, resolved once (a ValueError names a bad one)
    check_range("scenes", scenes, 1, MAX_SCENES)
    check_range("seed", seed, 0, SEED_MAX)
    root = Path(out)
    manifest_path = root / "manifest.json"
    generated_with = []  # the runs that wrote scenes: their versions and how many scenes
    if manifest_path.exists():
        old = read_json(manifest_path, "dataset manifest", dict, ("config", "seed"))
        generated_with = old.get("generated_with", [])
        if not resume:
            raise ValueError(f"out {root} already holds a dataset; pass resume=True (--resume)")
        defaults = dataclasses.asdict(SceneConfig())  # fields added later: their defaults
        recorded = {**defaults, **_as_made(old["config"]), "seed": old["seed"]}
        recorded = json.loads(json.dumps(recorded))
        wanted = json.loads(json.dumps({**dataclasses.asdict(cfg), "seed": seed}))
        differ = sorted(
            k for k in recorded.keys() | wanted.keys() if recorded.get(k) != wanted.get(k)
        )
        if differ:
            changes = "; ".join(
                f"{k}: {recorded.get(k)!r} recorded, {wanted.get(k)!r} given" for k in differ
            )
            raise ValueError(
                f"out {root} holds a dataset of another configuration ({changes}); resume it "
                "with the same options, or choose another out (--out)"
            )
    elif any((root / "scenes").glob("*.npz")) and not resume:
        raise ValueError(f"out {root} already holds scenes; pass resume=True (--resume)")
    pool = scene_pool(cfg)  # after the cheap checks: a bad --out is named before objects load
    with open_executor(parallel) as executor:  # a cluster is joined before anything is written
        if not manifest_path.exists():  # records the configuration that --resume must match
            started = dataset_manifest(cfg, hand, seed, [], root, generated_with)
            write_atomic(manifest_path, lambda f: json.dump(started, f, indent=1), mode="w")
        databases, failed = _databases(cfg, hand, pool, root / "db", executor)
        if failed:
            raise TasksFailed(
                f"{len(failed)} of {cfg.pool_size} object databases failed, so no scene was "
                f"made (object {failed[0]['object']}: {failed[0]['error']})\n"
                + failed[0]["traceback"]
            )
        todo = scenes_to_write(root, range(scenes), resume)
        job = Job(_scene_task, _setup, (cfg, hand, seed, databases))
        run = {"scenes": 0, "versions": versions()}  # this run, in the record once it writes

        def record() -> None:  # the manifest in progress, its counts those of the scenes on disk
            runs = [*generated_with, run]
            manifest = dataset_manifest(cfg, hand, seed, [], root, runs)
            write_atomic(manifest_path, lambda f: json.dump(manifest, f, indent=1), mode="w")

        try:
            for i, result in executor.map(job, todo, "scenes"):
                if isinstance(result, Failure):
                    failed.append(_failure("scene", i, seed, result))
                else:
                    _write_bytes(scene_path(root, i), result)
                    run["scenes"] += 1
                    record()  # a few kB per scene: even a killed run leaves a true count
        except BaseException:  # interrupted, perhaps inside record(): the count as it stands
            if run["scenes"]:
                record()
            raise
    if run["scenes"]:
        generated_with = [*generated_with, run]

    done = [i for i in range(scenes) if scene_path(root, i).exists()]
    manifest = dataset_manifest(cfg, hand, seed, done, root, generated_with)
    if failed:
        manifest["failed"] = failed
    write_atomic(manifest_path, lambda f: json.dump(manifest, f, indent=1), mode="w")
    if failed:
        raise TasksFailed(
            f"{len(failed)} of {len(todo)} scenes failed (scene {failed[0]['scene']}: "
            f"{failed[0]['error']}); the others are written, the failures and their tracebacks "
            f"are under 'failed' in {manifest_path}, --resume runs them again"
        )
    return manifest
