"""A bare mesh file (OBJ, STL or PLY) → an `ObjectSpec` of convex parts.

A bare mesh gives a shape and nothing else; the rest is assumed, and said:

- **units**: ``mesh_unit`` "m", "cm" or "mm"; "auto" reads a mesh whose longest side exceeds
  `MILLIMETRE_HINT` file units as millimetres (a warning naming the file says so), any
  other as metres;
- **mass**: `DEFAULT_DENSITY` × the mesh's volume;
- **friction**: `symgrasp.objects.urdf.DEFAULT_FRICTION` (1.0, as every VGN object);
- **frame**: as `symgrasp.objects.urdf.load_urdf`'s: origin at the centre of the bounding
  box's base, +z up as in the file;
- **collision**: a convex mesh (hull volume within `CONVEX_TOLERANCE` of its volume) is one
  part, its hull; any other is cut into convex parts once (`symgrasp.objects.decomposition`).

Vertices at one position are merged (an STL stores each triangle's own, an OBJ splits them at
texture seams), except in a file that is closed as stored and that merging would open (seen
in GraspNet-1Billion-style ``convex.obj`` models): two solids touching along an edge share it
once merged, four faces on one edge, which is not watertight.

A file that is not a readable mesh, holds no triangles or spans no volume is refused with a
ValueError naming it. So is a mesh that is not watertight, unless its holes are single
triangles or quads (filled, with a warning naming it): it has no inside to weigh, and CoACD
would first remesh it into a manifold, a thickened shell of the surface (458 s and 77 parts
for a 256-face cup missing its base, against 10 s and 24 parts for the closed cup).

A folder of bare meshes (`mesh_files`) holds mesh files, or sub-folders that each hold one.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from symgrasp.folders import check_file_name
from symgrasp.names import MESH_UNITS
from symgrasp.objects.decomposition import DEFAULT_PRESET, decompose
from symgrasp.objects.urdf import DEFAULT_FRICTION, convex_parts, object_colour
from symgrasp.sim.objects import ObjectSpec

if TYPE_CHECKING:
    import trimesh

MESH_SUFFIXES = (".obj", ".stl", ".ply")
"""File suffixes of bare meshes (any case)."""

COMPANION_SUFFIXES = (".mtl", ".png", ".jpg", ".jpeg", ".tga", ".bmp")
"""Files that travel with meshes (OBJ materials, textures): skipped without a word."""

UNIT_METRES = {"m": 1.0, "cm": 0.01, "mm": 0.001}
"""Metres per file unit."""

MILLIMETRE_HINT = 2.0
"""A mesh longer than this [file units] is read as millimetres by ``mesh_unit="auto"``: no
object of the 30 cm workspace is 2 m long, and few are under 2 mm."""

DEFAULT_DENSITY = 700.0
"""Density [kg/m³] of a bare mesh: the median of mass / visual-mesh volume over VGN's 473
URDF objects (quartiles 700 and 1433 kg/m³; docs/objects.md)."""

CONVEX_TOLERANCE = 0.01
"""A watertight mesh whose convex hull is at most this much larger (relative volume) is convex:
one part, no decomposition."""


LARGE_MESH_FACES = 100_000
"""A mesh of more faces than this is slow to become an object, and reading it says so: its
hull, watertightness, convex parts and MuJoCo's compile of them grow with the faces, about a
minute per million faces on one core (a 1.3 M-face mesh took 79 s in ``objects inspect`` and
136 s in ``sim show`` on the 2-core reference machine; docs/objects.md)."""

SECONDS_PER_FACE = 6e-5
"""[s] what `LARGE_MESH_FACES` quotes per face, for the estimate read_mesh gives."""


@dataclass(frozen=True)
class BareMesh:
    """A mesh file as read: ``mesh`` in the file's units, ``unit`` the units it is read in
    (a key of `UNIT_METRES`), ``guessed`` whether ``mesh_unit="auto"`` chose them."""

    path: Path
    mesh: trimesh.Trimesh
    unit: str
    guessed: bool

    @property
    def metres(self) -> float:
        """Metres per file unit."""
        return UNIT_METRES[self.unit]


def read_mesh(path: str | Path, mesh_unit: str = "auto") -> BareMesh:
    """The triangles of the mesh file ``path`` and its units (``mesh_unit``, or guessed from its
    size: module doc; `load_mesh` says so). Vertices at one position are merged unless that
    opens a file that is closed as stored (module doc). Raises ValueError naming the file when
    it is not a mesh trimesh reads or holds no triangles."""
    import trimesh

    path = Path(path)
    if mesh_unit not in MESH_UNITS:
        raise ValueError(f"mesh_unit must be one of {MESH_UNITS}, got {mesh_unit!r}")
    try:
        stored = trimesh.load(path, force="mesh", process=False, skip_materials=True)
    except Exception as error:  # trimesh's loaders raise many kinds on a foreign file
        raise ValueError(f"{path} is not a mesh trimesh can read: {error}") from None
    if not isinstance(stored, trimesh.Trimesh) or len(stored.faces) == 0:
        raise ValueError(f"{path} holds no triangles: not an OBJ, STL or PLY mesh")
    mesh = stored.copy().process()  # an STL's triangle soup, an OBJ's UV seams: joined
    if not mesh.is_watertight and stored.is_watertight:
        mesh = stored  # merging pinched a closed file (solids touching at an edge or vertex)
    if len(mesh.faces) > LARGE_MESH_FACES:
        warnings.warn(
            f"{path}: {len(mesh.faces):,} faces: making it an object takes about "
            f"{len(mesh.faces) * SECONDS_PER_FACE:.0f} s or more (a minute per million faces); "
            "a simplified copy is faster",
            stacklevel=2,
        )
    if mesh_unit != "auto":
        return BareMesh(path, mesh, mesh_unit, guessed=False)
    return BareMesh(path, mesh, "mm" if mesh.extents.max() > MILLIMETRE_HINT else "m", True)


def load_mesh(
    path: str | Path,
    mesh_unit: str = "auto",
    name: str | None = None,
    decomposition: str = DEFAULT_PRESET,
) -> ObjectSpec:
    """The object of the bare mesh file ``path`` (module doc), named ``name`` (default: the
    file's stem), a concave one cut into convex parts by the preset ``decomposition``
    (`symgrasp.objects.decomposition.PRESETS`). Raises ValueError naming the file when it is
    refused."""
    import trimesh

    bare = read_mesh(path, mesh_unit)
    mesh, path = bare.mesh, bare.path
    name = check_file_name(name or path.stem, f"{path}: the object's name")
    try:
        with np.errstate(divide="ignore", invalid="ignore"):  # a flat hull's centre of mass
            hull = mesh.convex_hull
    except Exception:  # qhull refuses flat point sets
        hull = None
    if hull is None or hull.volume * bare.metres**3 <= 1e-12:
        raise ValueError(f"{path} spans no volume (a flat or degenerate mesh)")
    if not mesh.is_watertight:
        open_edges = len(trimesh.grouping.group_rows(mesh.edges_sorted, require_count=1))
        if not trimesh.repair.fill_holes(mesh):
            raise ValueError(
                f"{path} is not watertight ({open_edges} open edges; holes larger than a quad "
                "or non-manifold edges): it has no inside to weigh or cut into convex parts; "
                "close it (e.g. MeshLab, or trimesh.repair.fill_holes(mesh, use_fan=True))"
            )
        warnings.warn(f"{path}: {open_edges} open edges closed (small holes filled)", stacklevel=2)
    trimesh.repair.fix_normals(mesh, multibody=True)  # outward faces: a positive volume
    volume = float(mesh.volume)
    if volume * bare.metres**3 <= 1e-12:
        raise ValueError(f"{path} encloses no volume (its faces cancel out)")
    if bare.guessed and bare.unit == "mm":
        longest = float(mesh.extents.max())
        warnings.warn(
            f"{path}: longest side {longest:.4g} file units, read as millimetres "
            f"({longest / 1000:.3f} m); --mesh-unit (mesh_unit) sets the units",
            stacklevel=2,
        )
    if hull.volume <= (1 + CONVEX_TOLERANCE) * volume:
        groups = [hull.vertices]
    else:
        groups = decompose(path, mesh.vertices, mesh.faces, decomposition)
    parts = convex_parts([np.asarray(g) * bare.metres for g in groups], path)
    mass = DEFAULT_DENSITY * volume * bare.metres**3
    return ObjectSpec(name, name, parts, mass, DEFAULT_FRICTION, object_colour(name))


def _kind(path: Path) -> str:
    """ "mesh", "companion" or "other": what a file found in a mesh folder is."""
    suffix = path.suffix.lower()
    if suffix in MESH_SUFFIXES:
        return "mesh"
    return "companion" if suffix in COMPANION_SUFFIXES or path.name.startswith(".") else "other"


def mesh_files(folder: Path) -> tuple[Path, ...]:
    """The bare meshes of ``folder``, sorted by name: its mesh files, and the one mesh of each
    sub-folder. A file that is neither a mesh nor a mesh's companion (`COMPANION_SUFFIXES`)
    and a sub-folder without a mesh are skipped with a warning naming them; a sub-folder
    holding several meshes is refused (ValueError naming them: which one is the object?). A
    sub-folder that is a link back to ``folder`` or a folder above it (a loop) is skipped with a
    warning: it holds no object of its own."""
    found = []
    for entry in sorted(folder.iterdir()):
        hidden = entry.name.startswith(".")
        if entry.is_dir() and not hidden and folder.resolve().is_relative_to(entry.resolve()):
            warnings.warn(
                f"{entry} links back to {entry.resolve()} (a loop): skipped", stacklevel=2
            )
        elif entry.is_dir() and not hidden:
            meshes = sorted(p for p in entry.iterdir() if p.is_file() and _kind(p) == "mesh")
            if len(meshes) > 1:
                names = ", ".join(p.name for p in meshes)
                raise ValueError(
                    f"{entry} holds {len(meshes)} meshes ({names}): a sub-folder of a mesh "
                    "folder holds one object, one mesh"
                )
            if not meshes:
                warnings.warn(f"{entry} holds no .obj, .stl or .ply mesh: skipped", stacklevel=2)
            found += meshes
        elif entry.is_file() and _kind(entry) == "mesh":
            found.append(entry)
        elif entry.is_file() and _kind(entry) == "other":
            warnings.warn(f"{entry} is not an .obj, .stl or .ply mesh: skipped", stacklevel=2)
    return tuple(found)
