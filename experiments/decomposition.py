"""Convex decomposition libraries on concave meshes → experiments/results/decomposition.json.

    SYMGRASP_DATA=../shared PYTHONPATH=src python experiments/decomposition.py [--points 20000]
        [--out experiments/results/decomposition.json] [--quick [DIR]]

Bare meshes need a convex decomposition (MuJoCo collides each mesh geom as its convex hull);
this picks the library and its settings. The meshes: VGN's visual meshes of concave objects
(`VGN_MESHES`, from ``vgn-pile-train`` in the data folder) and two procedural solids of
revolution with a known cavity (`cup`, `bowl`). Per setting of each library (`SETTINGS`) and
mesh: the seconds of one decomposition, the parts, and the fidelity of the union of parts on
``--points`` points drawn uniformly in the mesh's bounding box: the volume IoU with the mesh
(inside the mesh by winding number), ``filled``, the share of the concavity (inside the
mesh's convex hull, outside the mesh) that the parts fill (0 is ideal, 1 a single hull), and
for the procedural meshes ``cavity``, the share of points of the cavity (shrunk by 2 mm) that
lie inside a part (0: a hand or another object fits in). VGN's shipped collision
decomposition of the same objects is scored the same way (setting ``vgn-shipped``). A library
that is not installed is left out (``vhacdx`` is no dependency of symgrasp: ``pip install
vhacdx`` to compare). ``--quick``: the procedural cup only, 2 000 points, CoACD's default and
V-HACD's cheaper setting.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import statistics
import time
from collections.abc import Callable

import numpy as np
import trimesh
from scipy.spatial import ConvexHull
from scripts import command_line, parse_args, run_main, write_result

from symgrasp.objects.folder import set_folder
from symgrasp.objects.urdf import read_obj_groups

VGN_MESHES = (
    "mug",
    "bowl_poisson_005",
    "GreenCup_800_tex",
    "pan_poisson_017",
    "champagne_glass_poisson_001",
    "watering_can_poisson_001",
)
"""Concave objects of ``vgn-pile-train`` (hull volume ≥ 1.25 × mesh volume)."""

CAVITY_MARGIN = 0.002
"""The procedural cavities are shrunk by this much [m] before parts are tested against them."""


def _coacd(threshold: float, max_hulls: int = -1) -> Callable[[trimesh.Trimesh], list]:
    def run(mesh: trimesh.Trimesh) -> list[np.ndarray]:
        import coacd

        coacd.set_log_level("error")
        parts = coacd.run_coacd(
            coacd.Mesh(mesh.vertices, mesh.faces), threshold=threshold, max_convex_hull=max_hulls
        )
        return [np.asarray(vertices) for vertices, _ in parts]

    return run


def _vhacd(max_hulls: int, resolution: int) -> Callable[[trimesh.Trimesh], list]:
    def run(mesh: trimesh.Trimesh) -> list[np.ndarray]:
        parts = trimesh.decomposition.convex_decomposition(
            mesh, maxConvexHulls=max_hulls, resolution=resolution
        )
        return [np.asarray(part["vertices"]) for part in parts]

    return run


SETTINGS = {
    "coacd threshold=0.05": _coacd(0.05),
    "coacd threshold=0.1": _coacd(0.1),
    "vhacd hulls=64 resolution=400000": _vhacd(64, 400_000),
    "vhacd hulls=16 resolution=100000": _vhacd(16, 100_000),
}
"""Library settings compared: CoACD's default (threshold 0.05) and a coarser one; V-HACD's
defaults (as trimesh passes them) and a cheaper one."""

QUICK_SETTINGS = ("coacd threshold=0.05", "vhacd hulls=16 resolution=100000")
LIBRARIES = {"coacd": "coacd", "vhacd": "vhacdx"}
"""The module each setting's library needs, by the setting's first word."""


def revolved(profile: list[tuple[float, float]]) -> trimesh.Trimesh:
    """The watertight solid swept by the closed (r, z) ``profile`` [m] about +z (its ends on
    the axis)."""
    return trimesh.creation.revolve(np.array(profile), sections=48)


def cup() -> tuple[trimesh.Trimesh, Callable[[np.ndarray], np.ndarray]]:
    """A cup 8 cm wide and 9 cm tall, 5 mm walls, 8 mm bottom, and its cavity test."""
    mesh = revolved([(0, 0), (0.04, 0), (0.04, 0.09), (0.035, 0.09), (0.035, 0.008), (0, 0.008)])
    m = CAVITY_MARGIN

    def cavity(p: np.ndarray) -> np.ndarray:
        radius = np.hypot(p[:, 0], p[:, 1])
        return (radius < 0.035 - m) & (p[:, 2] > 0.008 + m) & (p[:, 2] < 0.09 - m)

    return mesh, cavity


def bowl() -> tuple[trimesh.Trimesh, Callable[[np.ndarray], np.ndarray]]:
    """A spherical bowl (outer radius 7 cm, 6 mm wall, rim 5.6 cm above its base), and its
    cavity test."""
    outer, inner, rim = 0.07, 0.064, np.radians(75)
    angles = np.linspace(0, rim, 16)
    profile = [(outer * np.sin(a), outer - outer * np.cos(a)) for a in angles]
    profile += [(inner * np.sin(a), outer - inner * np.cos(a)) for a in angles[::-1]]
    mesh = revolved(profile)
    top = outer - outer * np.cos(rim)
    m = CAVITY_MARGIN

    def cavity(p: np.ndarray) -> np.ndarray:
        depth = np.linalg.norm(p - [0, 0, outer], axis=1)
        return (depth < inner - m) & (p[:, 2] < top - m)

    return mesh, cavity


def winding_inside(mesh: trimesh.Trimesh, points: np.ndarray) -> np.ndarray:
    """Whether each of ``points`` (N, 3) is inside the closed ``mesh``: its generalized winding
    number (Van Oosterom–Strackee solid angles) is above ½."""
    triangles = mesh.triangles
    inside = []
    for chunk in np.array_split(points, max(1, len(points) // 256)):
        a, b, c = (triangles[None, :, k] - chunk[:, None] for k in range(3))
        la, lb, lc = (np.linalg.norm(v, axis=-1) for v in (a, b, c))
        det = np.einsum("pfi,pfi->pf", a, np.cross(b, c))
        dots = (
            la * lb * lc
            + np.einsum("pfi,pfi->pf", a, b) * lc
            + np.einsum("pfi,pfi->pf", b, c) * la
            + np.einsum("pfi,pfi->pf", c, a) * lb
        )
        winding = np.arctan2(det, dots).sum(axis=1) / (2 * np.pi)
        inside.append(np.abs(winding) > 0.5)
    return np.concatenate(inside)


def inside_parts(parts: list[np.ndarray], points: np.ndarray) -> np.ndarray:
    """Whether each of ``points`` (N, 3) lies in the convex hull of any part."""
    inside = np.zeros(len(points), dtype=bool)
    for vertices in parts:
        equations = ConvexHull(vertices).equations
        inside |= np.all(points @ equations[:, :3].T + equations[:, 3] <= 1e-9, axis=1)
    return inside


def probe(
    mesh: trimesh.Trimesh, points: int, cavity: Callable[[np.ndarray], np.ndarray] | None
) -> dict[str, np.ndarray]:
    """The points that score a decomposition of ``mesh``: ``points`` (N, 3) uniform in its
    bounding box, which of them are inside it (``solid``) and in its concavity
    (``concave``), and the points of its ``cavity`` (procedural meshes; else none)."""
    rng = np.random.default_rng(0)
    p = rng.uniform(*mesh.bounds, size=(points, 3))
    solid = winding_inside(mesh, p)
    q = rng.uniform(*mesh.bounds, size=(points, 3))
    return {
        "points": p,
        "solid": solid,
        "concave": inside_parts([mesh.vertices], p) & ~solid,
        "cavity": q[cavity(q)] if cavity is not None else np.empty((0, 3)),
    }


def fidelity(probes: dict[str, np.ndarray], parts: list[np.ndarray]) -> dict[str, float]:
    """IoU, filled concavity and filled cavity of ``parts`` on a mesh's `probe` points."""
    solid, concave = probes["solid"], probes["concave"]
    covered = inside_parts(parts, probes["points"])
    scores = {
        "iou": float((solid & covered).sum() / (solid | covered).sum()),
        "filled": float((covered & concave).sum() / max(1, concave.sum())),
    }
    if len(probes["cavity"]):
        scores["cavity"] = float(inside_parts(parts, probes["cavity"]).mean())
    return scores


def vgn_meshes() -> dict[str, tuple[trimesh.Trimesh, list[np.ndarray]]]:
    """VGN's visual meshes of `VGN_MESHES` with their shipped collision parts (one frame)."""
    folder = set_folder("vgn-pile-train")
    return {
        name: (
            trimesh.load(folder / f"{name}_visual.obj", force="mesh"),
            read_obj_groups(folder / f"{name}_collision.obj"),
        )
        for name in VGN_MESHES
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--points", type=int, default=20_000, help="points per fidelity test (default: 20000)"
    )
    parser.add_argument(
        "--out", default="experiments/results/decomposition.json", help="result file (JSON)"
    )
    args = parse_args(
        parser, outputs=("out",), quick={"points": 2000}, also="the cup and 2 settings only"
    )
    procedural = {"cup": cup(), "bowl": bowl()}
    meshes = {name: (mesh, None, cavity) for name, (mesh, cavity) in procedural.items()}
    if not args.quick:
        meshes |= {name: (mesh, shipped, None) for name, (mesh, shipped) in vgn_meshes().items()}
    settings = {
        name: run
        for name, run in SETTINGS.items()
        if (name in QUICK_SETTINGS or not args.quick)
        and importlib.util.find_spec(LIBRARIES[name.split()[0]]) is not None
    }
    if args.quick:
        meshes = {"cup": meshes["cup"]}
    cells = []
    for name, (mesh, shipped, cavity) in meshes.items():
        probes = probe(mesh, args.points, cavity)
        runs = {"vgn-shipped": (lambda _, shipped=shipped: shipped)} if shipped else {}
        for setting, run in {**settings, **runs}.items():
            start = time.perf_counter()
            parts = run(mesh)
            seconds = time.perf_counter() - start
            cell = {"mesh": name, "setting": setting, "seconds": round(seconds, 2)}
            cell |= {"parts": len(parts), **fidelity(probes, parts)}
            cells.append({k: round(v, 3) if isinstance(v, float) else v for k, v in cell.items()})
            print(cells[-1], flush=True)
    summary = []
    for setting in {c["setting"]: None for c in cells}:
        mine = [c for c in cells if c["setting"] == setting]
        row = {"setting": setting, "meshes": len(mine)}
        for key in ("seconds", "parts", "iou", "filled"):
            row[key] = round(statistics.mean(c[key] for c in mine), 3)
        row["cavity_max"] = max((c["cavity"] for c in mine if "cavity" in c), default=None)
        summary.append(row)
    table = "| setting | meshes | s/mesh | parts | IoU | concavity filled | cavity filled (max) |\n"
    table += "|---|---|---|---|---|---|---|\n" + "".join(
        f"| {r['setting']} | {r['meshes']} | {r['seconds']:.1f} | {r['parts']:.1f} | "
        f"{r['iou']:.3f} | {r['filled']:.3f} | {r['cavity_max'] if r['cavity_max'] is not None else '–'} |\n"
        for r in summary
    )
    write_result(
        str(args.out).removesuffix(".json"),
        "convex decomposition of concave meshes",
        command_line(""),
        cells,
        table,
        summary=summary,
        points=args.points,
        cavity_margin_m=CAVITY_MARGIN,
        threads=os.cpu_count(),
    )
    print(table, end="")


if __name__ == "__main__":
    run_main(main)
