"""``symgrasp data generate``: databases, then scenes, into a resumable dataset folder.

Layout of a dataset folder::

    manifest.json          configuration, the gripper's whole spec, scene ids, hash, version
                           (written atomically)
    db/<object>_<gripper>_<key>.npz   per-object grasp databases (cache, reusable)
    scenes/scene_000123.npz           one compressed shard per scene

Every file is written to a temporary name and renamed, so an interrupted run loses only the
scenes in flight; ``resume=True`` skips the scenes already on disk. Work is split into pure
tasks — one per object database, one per scene id — run by a process pool of ``workers``;
any engine that maps a function over task arguments (e.g. Ray) could run them unchanged.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import multiprocessing
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ProcessPoolExecutor
from importlib.metadata import version
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from symgrasp.atomic import check_folder, write_atomic
from symgrasp.config import SEED_MAX, DatabaseConfig, SceneConfig, check_range
from symgrasp.data.dataset import load_scene, scene_path
from symgrasp.data.grasp_db import GraspDatabase, cached_database
from symgrasp.data.scenes import make_scene_record
from symgrasp.objects.sets import resolve
from symgrasp.sim.grippers import get_gripper
from symgrasp.workspace import RESOLUTION, VOXEL_SIZE


def config_from_dict(d: dict[str, Any]) -> SceneConfig:
    """The :class:`SceneConfig` saved in a manifest."""
    d = dict(d)
    db = d.pop("database")
    db["offset"] = tuple(db["offset"])
    for key in ("kinds", "camera_distance", "camera_polar"):
        d[key] = tuple(d[key])
    return SceneConfig(**d, database=DatabaseConfig(**db))


def _manifest(cfg: SceneConfig, seed: int, scene_ids: list[int], root: Path) -> dict[str, Any]:
    """The manifest of ``root`` holding ``scene_ids`` (an empty list while generating)."""
    return {
        "gripper": cfg.hand.to_dict(),
        "object_set": cfg.object_set,
        "k_max": cfg.k_max,
        "resolution": RESOLUTION,
        "voxel_size": VOXEL_SIZE,
        "num_scenes": len(scene_ids),
        "scene_ids": scene_ids,
        "seed": seed,
        "dataset_hash": dataset_hash(root, scene_ids),
        "symgrasp_version": version("symgrasp"),
        "config": dataclasses.asdict(cfg),
    }


def dataset_hash(root: Path, scene_ids: Iterable[int]) -> str:
    """SHA-256 over the ordered scene ids and the bytes of their files (first 16 hex)."""
    h = hashlib.sha256()
    for i in sorted(scene_ids):
        h.update(str(i).encode())
        h.update(hashlib.sha256(scene_path(root, i).read_bytes()).digest())
    return h.hexdigest()[:16]


# --- the pure tasks and their worker-side state -----------------------------------------

_WORKER: dict[str, Any] = {}


def _init_worker(cfg: SceneConfig, root: str, seed: int) -> None:
    import torch

    torch.set_num_threads(1)  # one core per worker: fusion threads would oversubscribe
    _WORKER.update(cfg=cfg, root=Path(root), seed=seed, dbs=None)


def _database_task(k: int) -> int:
    cfg: SceneConfig = _WORKER["cfg"]
    db = cached_database(cfg.pool()[k], cfg.hand, _WORKER["root"] / "db", cfg.database, seed=k)
    return len(db)


def _scene_task(scene_id: int) -> int:
    cfg: SceneConfig = _WORKER["cfg"]
    if _WORKER["dbs"] is None:
        _WORKER["dbs"] = load_databases(cfg, _WORKER["root"] / "db")
    record = make_scene_record(scene_id, cfg, _WORKER["dbs"], _WORKER["seed"])
    write_atomic(scene_path(_WORKER["root"], scene_id), lambda f: np.savez_compressed(f, **record))
    return len(record["voxel_index"])


def load_databases(cfg: SceneConfig, db_dir: str | Path) -> list[GraspDatabase]:
    """The pool's databases (built and cached where missing), in pool order."""
    return [
        cached_database(obj, cfg.hand, db_dir, cfg.database, seed=k)
        for k, obj in enumerate(cfg.pool())
    ]


def _run(
    task: Callable[[int], int], args: list[int], workers: int, init: tuple, desc: str
) -> Iterator[int]:
    bar = tqdm(total=len(args), desc=desc, unit="task", smoothing=0.1)
    if workers <= 1:
        _init_worker(*init)
        for a in args:
            yield task(a)
            bar.update()
    else:
        # spawn, not fork: a forked child inherits torch's thread pools and can deadlock
        spawn = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(workers, spawn, initializer=_init_worker, initargs=init) as pool:
            for value in pool.map(task, args, chunksize=1):
                yield value
                bar.update()
    bar.close()


MAX_SCENES = 10_000_000
"""Most scenes one dataset holds (≈ 10 GB of scene files at the default size)."""


def _of_a_dataset(name: str) -> bool:
    """Whether a dataset folder's entry may be called ``name`` (what generate, the card and
    `symgrasp data show` write there)."""
    return name in ("manifest.json", "db", "scenes", "card.json", "card.png") or (
        name.startswith("scene_") and name.endswith(".png")
    )


def check_names(object_set: str, gripper: str) -> None:
    """Raise ValueError listing the known names if either is unknown (or naming the bad key of
    a gripper spec file)."""
    resolve(object_set)
    get_gripper(gripper)


def generate(
    out: str | Path,
    cfg: SceneConfig,
    scenes: int,
    workers: int = 1,
    seed: int = 0,
    resume: bool = False,
) -> dict[str, Any]:
    """Write ``scenes`` labelled scenes (ids 0 … scenes − 1) to ``out``; returns the manifest.

    Raises ValueError if ``out`` already holds scenes and ``resume`` is False, or if it holds
    a dataset of another configuration or seed.
    """
    check_names(cfg.object_set, cfg.gripper)
    check_range("scenes", scenes, 1, MAX_SCENES)
    check_range("workers", workers, 1, 256)
    check_range("seed", seed, 0, SEED_MAX)
    root = check_folder(out)
    manifest_path = root / "manifest.json"
    foreign = sorted(p.name for p in root.glob("*") if not _of_a_dataset(p.name))
    if foreign and not manifest_path.exists():
        raise ValueError(
            f"out {root} holds files that are not a symgrasp dataset ({', '.join(foreign[:3])}"
            f"{', …' if len(foreign) > 3 else ''}); choose an empty or new folder"
        )
    if manifest_path.exists():
        old = json.loads(manifest_path.read_text())
        if not resume:
            raise ValueError(f"out {root} already holds a dataset; pass resume=True (--resume)")
        defaults = dataclasses.asdict(SceneConfig())  # fields added later: their defaults
        recorded = json.loads(json.dumps({**defaults, **old["config"]}))
        if recorded != json.loads(json.dumps(dataclasses.asdict(cfg))) or old["seed"] != seed:
            raise ValueError(f"out {root} holds a dataset of another configuration or seed")
    elif any((root / "scenes").glob("*.npz")) and not resume:
        raise ValueError(f"out {root} already holds scenes; pass resume=True (--resume)")
    root.mkdir(parents=True, exist_ok=True)
    if not manifest_path.exists():  # records the configuration that --resume must match
        started = _manifest(cfg, seed, [], root)
        write_atomic(manifest_path, lambda f: json.dump(started, f, indent=1), mode="w")
    init = (cfg, str(root), seed)

    list(_run(_database_task, list(range(cfg.pool_size)), workers, init, "object databases"))

    todo = []
    for i in range(scenes):
        path = scene_path(root, i)
        if resume and path.exists():
            try:
                load_scene(path)
                continue
            except ValueError as err:
                print(f"regenerating {path}: {err}")
        todo.append(i)
    list(_run(_scene_task, todo, workers, init, "scenes"))

    done = [i for i in range(scenes) if scene_path(root, i).exists()]
    manifest = _manifest(cfg, seed, done, root)
    write_atomic(manifest_path, lambda f: json.dump(manifest, f, indent=1), mode="w")
    return manifest
