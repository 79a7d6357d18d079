"""Convex decomposition of a bare mesh, computed once and cached on disk.

MuJoCo collides a mesh geom as its convex hull, so a concave object (a mug, a bowl) must be
cut into convex parts first. A preset (`PRESETS`, ``--decomposition``) names the library and
its settings: V-HACD (Mamou et al., "Volumetric Hierarchical Approximate Convex
Decomposition", Game Engine Gems 3, 2016; version 4 through trimesh's ``vhacdx`` binding) or
CoACD (Wei et al., "Approximate Convex Decomposition for 3D Meshes with Collision-Aware
Concavity and Tree Search", SIGGRAPH 2022; the ``coacd`` package), both in the ``meshes``
extra. `DEFAULT_PRESET` was chosen by declutter outcomes and speed
(``experiments/decomposition_declutter.py``, ``benchmarks/objects.py``;
docs/reports/decomposition.md). A decomposition takes seconds to minutes, so it is kept in
``<data>/cache/decomposition/<key>.npz``, the key a hash of the mesh file's bytes and the
preset's settings: a second load of the same file reads the parts back without the library,
and another preset computes a new entry. Where the data folder cannot be written (a read-only
lab drive, CI's copy of the data), entries go to the per-user folder instead
(``~/.cache/symgrasp/cache/decomposition``), and both are read.
"""

from __future__ import annotations

import hashlib
import importlib
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

from symgrasp.atomic import write_atomic
from symgrasp.names import DECOMPOSITIONS
from symgrasp.objects.folder import data_folder, user_folder

PRESETS = {
    "vhacd-32": {"library": "vhacdx", "maxConvexHulls": 32, "resolution": 100_000,
                 "asyncACD": False},
    "vhacd": {"library": "vhacdx", "maxConvexHulls": 64, "resolution": 400_000,
              "asyncACD": False},
    "coacd": {"library": "coacd", "threshold": 0.05, "preprocess_mode": "auto", "seed": 0},
    "coacd-fast": {
        "library": "coacd", "threshold": 0.05, "preprocess_mode": "auto", "seed": 0,
        "mcts_iterations": 50, "mcts_nodes": 10, "resolution": 1000,
    },
}  # fmt: skip
"""The decompositions ``--decomposition`` offers, by name: each library's settings.
``vhacd-32``: V-HACD with at most 32 parts from 100 000 voxels; ``vhacd``: V-HACD's defaults as
trimesh passes them (at most 64 parts, 400 000 voxels); ``coacd``: CoACD's defaults, symgrasp's
decomposition before issue 66 (the concavity threshold 0.05 is relative to the mesh's size);
``coacd-fast``: its tree search a third as long and half as wide, half its sampling. V-HACD
works on voxels of the mesh's bounding box, so its time hardly grows with the faces (CoACD's
does: minutes a mesh at 50 k faces), and runs on the calling thread (``asyncACD`` off): a
worker is one core, and its parts are the same on every run."""

DEFAULT_PRESET = DECOMPOSITIONS[0]
"""The preset every command uses unless told otherwise (docs/reports/decomposition.md)."""

BEFORE_PRESETS = "coacd"
"""The preset whose settings were symgrasp's only decomposition before the presets: what a
record without a ``decomposition`` was made with
(`symgrasp.objects.sets.unrecorded_decomposition`)."""

LIBRARIES = {"coacd": "coacd", "vhacdx": "vhacdx"}
"""The module each preset's ``library`` imports."""

CACHE = Path("cache") / "decomposition"
"""The decompositions, relative to the data folder."""

EXTRA = "pip install 'symgrasp[meshes]'"
"""How to install the decomposition libraries."""


def preset_settings(preset: str) -> dict:
    """The settings of the preset named ``preset``. Raises ValueError naming
    ``--decomposition`` and the presets when it is none of `PRESETS`."""
    if preset not in PRESETS:
        raise ValueError(f"--decomposition must be one of {', '.join(PRESETS)}, got {preset!r}")
    return PRESETS[preset]


def cache_key(data: bytes, settings: dict) -> str:
    """The cache entry of a mesh file's bytes ``data`` decomposed with ``settings`` (hex)."""
    digest = hashlib.sha256(data)
    digest.update(json.dumps(settings, sort_keys=True).encode())
    return digest.hexdigest()[:32]


def run_library(vertices: np.ndarray, faces: np.ndarray, settings: dict) -> list[np.ndarray]:
    """The convex parts of the mesh (``vertices`` (V, 3), ``faces`` (F, 3) indices) as
    (P_k, 3) vertex arrays in the mesh's units, by the library ``settings`` name with the rest
    of its settings. Raises ModuleNotFoundError naming the extra when that library is not
    installed."""
    library, options = settings["library"], {k: v for k, v in settings.items() if k != "library"}
    try:
        module = importlib.import_module(LIBRARIES[library])
    except ModuleNotFoundError:
        raise ModuleNotFoundError(
            f"bare meshes need the convex decomposition library {LIBRARIES[library]}: {EXTRA}"
        ) from None
    if library == "vhacdx":  # faces as VTK polygons, each (3, i, j, k), as trimesh passes them
        polygons = np.column_stack([np.full(len(faces), 3), faces]).ravel().astype(np.uint32)
        parts = module.compute_vhacd(np.asarray(vertices, dtype=float), polygons, **options)
    else:
        module.set_log_level("error")
        parts = module.run_coacd(module.Mesh(vertices, faces), **options)
    return [np.asarray(part_vertices, dtype=float) for part_vertices, _ in parts]


def decompose(
    path: Path, vertices: np.ndarray, faces: np.ndarray, preset: str = DEFAULT_PRESET
) -> list[np.ndarray]:
    """The convex parts (each a (P_k, 3) vertex array, in the file's units) of the mesh read
    from ``path`` (``vertices`` (V, 3), ``faces`` (F, 3)) by the `PRESETS` entry ``preset``:
    from the cache when the file was decomposed with its settings before, else computed
    (saying so on stderr) and stored."""
    settings = preset_settings(preset)
    name = f"{cache_key(path.read_bytes(), settings)}.npz"
    for folder in cache_folders():
        if (folder / name).is_file():
            with np.load(folder / name) as stored:
                return np.split(stored["vertices"], np.cumsum(stored["counts"])[:-1])
    folder = next((f for f in cache_folders() if _writable(f)), None)
    where = f"cached in {folder}" if folder else "not cached: no cache folder can be written"
    from tqdm import tqdm  # its write keeps the line off a progress bar of this process

    tqdm.write(f"decomposing {path} into convex parts ({preset}, once; {where})", sys.stderr)
    parts = run_library(vertices, faces, settings)
    if folder is not None:
        counts = np.array([len(p) for p in parts])
        write_atomic(
            folder / name, lambda f: np.savez(f, vertices=np.concatenate(parts), counts=counts)
        )
    return parts


def cache_folders() -> tuple[Path, ...]:
    """Where decompositions are looked for, in order, and stored in the first that can be
    written: the data folder's cache, then the per-user one."""
    return tuple(dict.fromkeys((data_folder() / CACHE, user_folder() / CACHE)))


def _writable(folder: Path) -> bool:
    """Whether a file can be created in ``folder`` (made if missing): tried, since permission
    bits do not tell a read-only mount, nor stop root."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=folder):
            return True
    except OSError:
        return False
