"""Convex decomposition of a bare mesh, computed once and cached on disk.

MuJoCo collides a mesh geom as its convex hull, so a concave object (a mug, a bowl) must be
cut into convex parts first. The parts come from CoACD (Wei et al., "Approximate Convex
Decomposition for 3D Meshes with Collision-Aware Concavity and Tree Search", SIGGRAPH 2022;
the ``coacd`` package of the ``meshes`` extra), chosen over V-HACD by
``experiments/decomposition.py`` (docs/objects.md has the numbers). A decomposition takes
seconds to a minute, so it is kept in ``<data>/cache/decomposition/<key>.npz``, the key a
hash of the mesh file's bytes and the `SETTINGS`: a second load of the same file reads the
parts back without the library, and changed settings compute a new entry. Where the data
folder cannot be written (a read-only lab drive, CI's copy of the data), entries go to the
per-user folder instead (``~/.cache/symgrasp/cache/decomposition``), and both are read.
"""

from __future__ import annotations

import hashlib
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

from symgrasp.atomic import write_atomic
from symgrasp.objects.folder import data_folder, user_folder

SETTINGS = {"library": "coacd", "threshold": 0.05, "preprocess_mode": "auto", "seed": 0}
"""CoACD's settings (its defaults; the concavity threshold 0.05 is relative to the mesh's
size, so the parts do not depend on the file's units)."""

CACHE = Path("cache") / "decomposition"
"""The decompositions, relative to the data folder."""

EXTRA = "pip install 'symgrasp[meshes]'"
"""How to install the decomposition library."""


def cache_key(data: bytes, settings: dict) -> str:
    """The cache entry of a mesh file's bytes ``data`` decomposed with ``settings`` (hex)."""
    digest = hashlib.sha256(data)
    digest.update(json.dumps(settings, sort_keys=True).encode())
    return digest.hexdigest()[:32]


def run_coacd(vertices: np.ndarray, faces: np.ndarray, settings: dict) -> list[np.ndarray]:
    """CoACD's convex parts of the mesh (``vertices`` (V, 3), ``faces`` (F, 3) indices) as
    (P_k, 3) vertex arrays in the mesh's units. Raises ModuleNotFoundError naming the extra
    when CoACD is not installed."""
    try:
        import coacd
    except ModuleNotFoundError:
        raise ModuleNotFoundError(
            f"bare meshes need a convex decomposition library: {EXTRA}"
        ) from None
    coacd.set_log_level("error")
    options = {k: v for k, v in settings.items() if k != "library"}
    parts = coacd.run_coacd(coacd.Mesh(vertices, faces), **options)
    return [np.asarray(part_vertices, dtype=float) for part_vertices, _ in parts]


def decompose(
    path: Path, vertices: np.ndarray, faces: np.ndarray, settings: dict = SETTINGS
) -> list[np.ndarray]:
    """The convex parts (each a (P_k, 3) vertex array, in the file's units) of the mesh read
    from ``path`` (``vertices`` (V, 3), ``faces`` (F, 3)): from the cache when the file was
    decomposed with ``settings`` before, else computed (saying so on stderr) and stored."""
    name = f"{cache_key(path.read_bytes(), settings)}.npz"
    for folder in cache_folders():
        if (folder / name).is_file():
            with np.load(folder / name) as stored:
                return np.split(stored["vertices"], np.cumsum(stored["counts"])[:-1])
    folder = next((f for f in cache_folders() if _writable(f)), None)
    where = f"cached in {folder}" if folder else "not cached: no cache folder can be written"
    print(f"decomposing {path} into convex parts (once; {where})", file=sys.stderr)
    parts = run_coacd(vertices, faces, settings)
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
