"""``symgrasp objects inspect`` of a folder of 50 meshes of 10 k–100 k faces, per convex
decomposition preset, cold cache → benchmarks/results/objects.json.

    SYMGRASP_DATA=../shared PYTHONPATH=src python benchmarks/objects.py [--meshes 50]
        [--workers 2] [--presets vhacd-32 vhacd ...] [--slow-meshes 4] [--out ...]
        [--quick [DIR]]

The meshes (`generate`, written under ``out/objects-meshes``, never tracked; the same files on
every run): three in five are concave VGN visual meshes of ``vgn-pile-train`` (hull volume over
1.05 × their volume, drawn with seed 0) cut into four triangles per triangle (same shape)
until they hold 10 k–100 k faces, saved as OBJ; the others are procedural STL solids, a
lumpy sphere (EGAD-like: an icosphere's radius modulated by three random waves) or a torus,
4–10 cm across. They are named in shuffled order, so that the first N are a sample of all.

Per preset (`symgrasp.objects.decomposition.PRESETS`): the command on a fresh data folder and
per-user cache (nothing decomposed yet), with ``--workers``, timed from start to exit (reading,
decomposing, the report and the contact sheet), and each object's parts from its report.
Presets in `SLOW` take minutes a mesh on these meshes, so they are timed on the first
``--slow-meshes`` meshes only and their time for all is the per-mesh time scaled (said in the
cell). Needs VGN's object sets (``symgrasp objects fetch vgn``); exits 66 without them.
``--quick``: 3 meshes of 1 k–6 k faces (one VGN mesh, a lumpy sphere, a torus), ``vhacd-32``
only.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import re
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import lab  # noqa: F401  (puts the checkout's root on sys.path, for experiments.scripts)
import numpy as np
import trimesh

from experiments.scripts import command_line, parse_args, run_main, write_result
from symgrasp.names import DECOMPOSITIONS
from symgrasp.objects.decomposition import EXTRA, LIBRARIES, PRESETS
from symgrasp.objects.folder import set_folder

FACES = (10_000, 100_000)
"""The range of the meshes' face counts."""

QUICK_FACES = (1_000, 6_000)
"""The range ``--quick`` uses, for seconds."""

SLOW = ("coacd", "coacd-fast")
"""Presets timed on ``--slow-meshes`` meshes only (module doc)."""

MESHES = Path("out/objects-meshes")
"""Where `generate` writes the meshes."""


def subdivided(
    mesh: trimesh.Trimesh, faces: tuple[int, int], rng: np.random.Generator
) -> trimesh.Trimesh:
    """``mesh`` with each triangle cut into four (its shape unchanged) a number of times drawn
    from those that put its faces in the range ``faces``."""
    counts = [k for k in range(8) if faces[0] <= len(mesh.faces) * 4**k <= faces[1]]
    vertices, triangles = mesh.vertices, mesh.faces
    for _ in range(int(rng.choice(counts))):
        vertices, triangles = trimesh.remesh.subdivide(vertices, triangles)
    return trimesh.Trimesh(vertices, triangles)


def lumpy_sphere(faces: tuple[int, int], rng: np.random.Generator) -> trimesh.Trimesh:
    """An icosphere of 20 × 4ᵏ faces in the range ``faces``, 2–5 cm in radius, each vertex's
    radius scaled by 1 + the sum of three waves of amplitude 0.12 along random directions: a
    smooth, concave, star-shaped solid."""
    levels = [k for k in range(8) if faces[0] <= 20 * 4**k <= faces[1]]
    sphere = trimesh.creation.icosphere(subdivisions=int(rng.choice(levels)))
    directions = rng.normal(size=(3, 3))
    frequencies, phases = rng.uniform(2, 5, 3), rng.uniform(0, 2 * np.pi, 3)
    waves = np.sin(sphere.vertices @ directions.T * frequencies + phases).sum(axis=1)
    radius = rng.uniform(0.02, 0.05) * (1 + 0.12 * waves)
    return trimesh.Trimesh(sphere.vertices * radius[:, None], sphere.faces)


def torus(faces: tuple[int, int], rng: np.random.Generator) -> trimesh.Trimesh:
    """A torus 3–4.5 cm in major radius, 0.8–1.5 cm in minor, of about a number of faces drawn
    log-uniformly in the range ``faces`` (2 × major × minor sections, twice as many major)."""
    minor = int(np.sqrt(np.exp(rng.uniform(*np.log(faces))) / 4))
    return trimesh.creation.torus(
        rng.uniform(0.03, 0.045), rng.uniform(0.008, 0.015),
        major_sections=2 * minor, minor_sections=minor,
    )  # fmt: skip


def concave_vgn_meshes() -> list[Path]:
    """The visual meshes of ``vgn-pile-train`` whose hull is over 1.05 × their volume."""
    found = []
    for path in sorted(set_folder("vgn-pile-train").glob("*_visual.obj")):
        mesh = trimesh.load(path, force="mesh")
        if mesh.is_watertight and mesh.convex_hull.volume > 1.05 * mesh.volume:
            found.append(path)
    return found


def generate(folder: Path, count: int, faces: tuple[int, int] = FACES, seed: int = 0) -> list[Path]:
    """Write ``count`` meshes (module doc) of face counts in the range ``faces`` into ``folder``
    (replacing what it held) and return their paths in name order; the same files for the same
    arguments."""
    rng = np.random.default_rng(seed)
    vgn = concave_vgn_meshes()
    kinds = ["vgn"] * (3 * count // 5) + ["sphere"] * (count // 3)
    kinds += ["torus"] * (count - len(kinds))
    picks = iter(rng.choice(len(vgn), size=kinds.count("vgn"), replace=False))
    folder.mkdir(parents=True, exist_ok=True)
    for old in folder.iterdir():
        old.unlink()
    paths = []
    for index, k in enumerate(rng.permutation(len(kinds))):
        kind = kinds[k]
        if kind == "vgn":
            source = vgn[next(picks)]
            mesh = subdivided(trimesh.load(source, force="mesh"), faces, rng)
            name = source.stem.removesuffix("_visual")
            path = folder / f"{index:02d}_{name}.obj"
        else:
            mesh = lumpy_sphere(faces, rng) if kind == "sphere" else torus(faces, rng)
            path = folder / f"{index:02d}_{kind}.stl"
        mesh.export(path)
        paths.append(path)
    return paths


def inspect(folder: Path, preset: str, workers: int, cache: Path) -> dict:
    """``symgrasp objects inspect folder`` with ``preset`` and ``workers`` on an empty data
    folder and per-user cache under ``cache``: its seconds from start to exit, the CPU seconds
    of it and its workers (user + system: what a loaded machine does not stretch), and each
    object's parts."""
    environment = os.environ | {
        "SYMGRASP_DATA": str(cache / "data"),
        "XDG_CACHE_HOME": str(cache / "user"),
        "PYTHONPATH": "src",
    }
    command = [sys.executable, "-m", "symgrasp", "objects", "inspect", str(folder),
               "--decomposition", preset, "--workers", str(workers),
               "--out", str(cache / "sheet.png")]  # fmt: skip
    used = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(command, env=environment, capture_output=True, text=True)
    seconds = time.perf_counter() - start
    now = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = now.ru_utime - used.ru_utime + now.ru_stime - used.ru_stime
    if done.returncode != 0:
        raise RuntimeError(f"objects inspect with {preset} failed: {done.stderr.strip()[-500:]}")
    rows = re.findall(r"^\| (\S+) \| .* \| (\d+) \| (?:yes|no|–) \|$", done.stdout, re.MULTILINE)
    parts = {name: int(count) for name, count in rows if name != "object"}
    return {"seconds": seconds, "cpu_seconds": cpu, "parts": parts}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--meshes", type=int, default=50, help="meshes generated (default: 50)")
    parser.add_argument("--workers", type=int, default=2, help="inspect's --workers (default: 2)")
    parser.add_argument(
        "--presets", nargs="+", choices=DECOMPOSITIONS, default=list(DECOMPOSITIONS),
        help="decomposition presets timed (default: all)",
    )  # fmt: skip
    parser.add_argument(
        "--slow-meshes", type=int, default=4,
        help=f"meshes the slow presets ({', '.join(SLOW)}) are timed on (default: 4)",
    )  # fmt: skip
    parser.add_argument(
        "--out", default="benchmarks/results/objects", help="result stem (.json and .md)"
    )
    args = parse_args(
        parser,
        outputs=("out",),
        quick={"meshes": 3, "presets": ["vhacd-32"]},
        also="3 meshes",
    )
    for preset in args.presets:  # a missing library: one line, before any mesh is made
        library = LIBRARIES[PRESETS[preset]["library"]]
        if importlib.util.find_spec(library) is None:
            raise ModuleNotFoundError(f"the preset {preset} needs {library}: {EXTRA}")
    root = args.quick / "objects-meshes" if args.quick else MESHES
    paths = generate(root, args.meshes, QUICK_FACES if args.quick else FACES)
    faces = {p.stem: len(trimesh.load(p, force="mesh").faces) for p in paths}
    cells = []
    for preset in args.presets:
        meshes = paths[: args.slow_meshes] if preset in SLOW else paths
        with tempfile.TemporaryDirectory() as work:
            folder = Path(work) / "meshes"
            folder.mkdir()
            for path in meshes:
                (folder / path.name).symlink_to(path.resolve())
            run = inspect(folder, preset, args.workers, Path(work))
        per_mesh = run["seconds"] / len(meshes)
        cell = {
            "preset": preset,
            "meshes": len(meshes),
            "seconds": round(run["seconds"], 1),
            "cpu_seconds": round(run["cpu_seconds"], 1),
            "seconds_per_mesh": round(per_mesh, 2),
            "seconds_for_all": round(per_mesh * len(paths), 1),
            "cpu_seconds_for_all": round(run["cpu_seconds"] / len(meshes) * len(paths), 1),
            "scaled": len(meshes) < len(paths),
            "parts_mean": round(float(np.mean(list(run["parts"].values()))), 1),
            "parts": run["parts"],
        }
        cells.append(cell)
        print({k: v for k, v in cell.items() if k != "parts"}, flush=True)
    table = "| preset | meshes timed | s | CPU s | s for all | CPU s for all | parts (mean) |\n"
    table += "|---|---|---|---|---|---|---|\n" + "".join(
        f"| {c['preset']} | {c['meshes']} | {c['seconds']:.0f} | {c['cpu_seconds']:.0f} | "
        f"{c['seconds_for_all']:.0f}{' (scaled)' if c['scaled'] else ''} | "
        f"{c['cpu_seconds_for_all']:.0f} | {c['parts_mean']:.1f} |\n"
        for c in cells
    )
    write_result(
        args.out,
        "objects inspect of a folder of meshes, cold cache, per decomposition preset",
        command_line("SYMGRASP_DATA=../shared PYTHONPATH=src"),
        cells,
        table,
        meshes=len(paths),
        workers=args.workers,
        faces={"min": min(faces.values()), "median": int(np.median(list(faces.values()))),
               "max": max(faces.values()), "per_mesh": faces},
    )  # fmt: skip
    print(table, end="")


if __name__ == "__main__":
    run_main(main)
