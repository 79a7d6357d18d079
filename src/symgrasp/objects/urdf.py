"""A URDF object (VGN's format) → an `ObjectSpec` of convex parts.

VGN's objects (Breyer et al., CoRL 2020) are one link each: ``<inertial><mass>``, a
``<contact><lateral_friction>``, a visual mesh and a collision OBJ whose ``o``/``g`` groups are
the convex parts of a decomposition. MuJoCo collides a mesh geom as its convex hull, so each
group becomes one `ConvexPart`. The object frame is moved to the convention of
`symgrasp.sim.objects`: origin at the centre of the bounding box's base, +z up as in the file.
"""

from __future__ import annotations

import hashlib
import warnings
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from symgrasp.folders import check_file_name
from symgrasp.sim.objects import ConvexPart, ObjectSpec

DEFAULT_FRICTION = 1.0
"""Sliding friction when a URDF gives none (VGN's objects all give 1.0)."""


def read_obj_groups(path: Path) -> list[np.ndarray]:
    """The vertices used by each ``o``/``g`` group's faces of an OBJ file, as (V, 3) arrays
    (one group when the file has none). Texture and normal indices are ignored. Raises
    ValueError naming the file (and line) for a vertex or face that is not numbers, or a face
    naming a vertex the file does not hold."""
    vertices: list[list[float]] = []
    groups: list[set[int]] = [set()]
    for number, line in enumerate(path.read_text(errors="replace").splitlines(), 1):
        head, _, rest = line.partition(" ")
        if head == "v":
            values = rest.split()
            try:
                vertices.append([float(x) for x in values[:3]])
            except ValueError:
                raise ValueError(
                    f"{path}:{number}: a vertex needs 3 numbers, got {rest!r}"
                ) from None
        elif head in ("o", "g"):
            if groups[-1]:
                groups.append(set())
        elif head == "f":
            for corner in rest.split():
                try:
                    index = int(corner.split("/")[0])
                except ValueError:
                    raise ValueError(
                        f"{path}:{number}: a face needs vertex numbers, got {rest!r}"
                    ) from None
                if index == 0 or len(vertices) + index < 0:
                    raise ValueError(
                        f"{path}:{number}: a face names vertex {index}, out of range: "
                        f"{len(vertices)} vertices come before it"
                    )
                groups[-1].add(index - 1 if index > 0 else len(vertices) + index)
    if not vertices:
        raise ValueError(f"{path} holds no vertices: not an OBJ mesh")
    last = max(max(g, default=-1) for g in groups)
    if last >= len(vertices):
        raise ValueError(
            f"{path}: a face names vertex {last + 1}, out of range: the file holds "
            f"{len(vertices)} vertices"
        )
    v = np.asarray(vertices)
    return [v[sorted(g)] for g in groups if g] or [v]


def _float(element: ET.Element | None, default: float | None, what: str, path: Path) -> float:
    if element is None or element.get("value") is None:
        if default is None:
            raise ValueError(f"{path} gives no {what}")
        return default
    try:
        return float(element.get("value"))
    except ValueError:
        raise ValueError(f"{path}: {what} must be a number, got {element.get('value')!r}") from None


def _scale(text: str, path: Path) -> np.ndarray:
    """The mesh element's ``scale`` attribute: three positive finite numbers (x y z)."""
    try:
        scale = np.array([float(s) for s in text.split()])
    except ValueError:
        scale = np.array([])
    if scale.shape != (3,) or not (np.isfinite(scale).all() and (scale > 0).all()):
        raise ValueError(
            f"{path}: the mesh's scale must be three positive numbers (x y z), got {text!r}"
        )
    return scale


def object_colour(name: str) -> tuple[float, float, float, float]:
    """A fixed colour per object name, so pictures stay the same from run to run."""
    digest = hashlib.sha256(name.encode()).digest()
    return (*(round(0.15 + 0.8 * b / 255, 3) for b in digest[:3]), 1.0)


def load_urdf(path: str | Path) -> ObjectSpec:
    """The object of a one-link URDF with a collision mesh (OBJ of convex groups).

    The mass and friction are the URDF's; the parts are the collision OBJ's groups, scaled by
    the mesh element's ``scale``. A group too flat to hold volume is skipped with a warning.
    Raises FileNotFoundError (naming the URDF and the mesh) when the mesh is missing and
    ValueError when the file is not such a URDF.
    """
    path = Path(path)
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as error:
        raise ValueError(f"{path} is not a URDF (XML): {error}") from None
    link = root.find("link")
    mesh = root.find("link/collision/geometry/mesh")
    if root.tag != "robot" or link is None or mesh is None or not mesh.get("filename"):
        raise ValueError(f"{path} is not a one-link URDF with a collision mesh")
    name = check_file_name(root.get("name") or path.stem, f"{path}: the robot's name")
    mesh_path = path.parent / mesh.get("filename").removeprefix("package://")
    if not mesh_path.is_file():
        raise FileNotFoundError(f"{path} names the collision mesh {mesh_path}, which is missing")
    scale = _scale(mesh.get("scale", "1 1 1"), path)
    mass = _float(root.find("link/inertial/mass"), None, "mass (inertial/mass)", path)
    friction = _float(
        root.find("link/contact/lateral_friction"), DEFAULT_FRICTION, "friction", path
    )
    if not (mass > 0 and friction > 0):
        raise ValueError(f"{path}: mass and friction must be positive, got {mass}, {friction}")
    parts = convex_parts([g * scale for g in read_obj_groups(mesh_path)], mesh_path)
    return ObjectSpec(name, name, parts, mass, friction, object_colour(name))


def convex_parts(groups: list[np.ndarray], path: Path) -> tuple[ConvexPart, ...]:
    """The convex hulls of vertex ``groups`` ((V_k, 3) arrays [m], read from ``path``) moved to
    the object frame: origin at the centre of their bounding box's base, axes as in the file.
    A group too flat to hold volume is skipped with a warning naming the file; raises
    ValueError when none is left."""
    everything = np.concatenate(groups)
    low, high = everything.min(axis=0), everything.max(axis=0)
    origin = np.r_[(low[:2] + high[:2]) / 2, low[2]]
    parts = []
    for j, group in enumerate(groups):
        try:
            parts.append(ConvexPart(group - origin))
        except ValueError as error:
            warnings.warn(f"{path}: part {j} skipped: {error}", stacklevel=2)
    if not parts:
        raise ValueError(f"{path} holds no convex part with volume")
    return tuple(parts)
