"""What a folder of objects holds, for a person deciding whether to use it: per object its
units, size, mass, convex parts and whether its mesh is watertight, and a contact sheet of the
objects as MuJoCo collides them."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from symgrasp.config import ParallelConfig
from symgrasp.objects.mesh import MILLIMETRE_HINT, read_mesh
from symgrasp.objects.sets import ObjectSource
from symgrasp.parallel import Failure, Job, TasksFailed, open_executor
from symgrasp.sim.objects import ObjectSpec


@dataclass(frozen=True)
class ObjectReport:
    """One object of a folder, as `inspect_objects` found it: ``obj`` the object itself (for
    `contact_sheet`, without reading its file again)."""

    name: str
    units: str
    size_mm: tuple[float, float, float]
    mass_kg: float
    parts: int
    watertight: bool | None
    obj: ObjectSpec = field(repr=False, compare=False)

    def row(self) -> str:
        size = " × ".join(f"{s:.0f}" for s in self.size_mm)
        tight = {True: "yes", False: "no", None: "–"}[self.watertight]
        return (
            f"| {self.name} | {self.units} | {size} | {self.mass_kg:.3f} | {self.parts} | {tight} |"
        )


HEADER = (
    "| object | units | size [mm] | mass [kg] | parts | watertight |\n|---|---|---|---|---|---|"
)
"""The table's head: units as a bare mesh is read (guessed or given), or as a URDF's size
suggests ("mm?": likely millimetres); watertight: a bare mesh's, or a URDF's visual mesh's."""


def _visual_watertight(urdf: Path) -> bool | None:
    import trimesh

    mesh = ET.parse(urdf).getroot().find("link/visual/geometry/mesh")
    if mesh is None or not (urdf.parent / mesh.get("filename", "")).is_file():
        return None
    loaded = trimesh.load(urdf.parent / mesh.get("filename"), force="mesh", process=True)
    return bool(loaded.is_watertight)


def _bare_mesh(path: Path, mesh_unit: str) -> tuple[str, bool]:
    """A bare mesh's units as read ("mm (guessed)", "cm (given)") and whether it is
    watertight."""
    bare = read_mesh(path, mesh_unit)
    return f"{bare.unit} ({'guessed' if bare.guessed else 'given'})", bool(bare.mesh.is_watertight)


def inspect_objects(
    source: ObjectSource, parallel: ParallelConfig = ParallelConfig()
) -> tuple[list[ObjectReport], list[str]]:
    """A report per usable object of a mesh set (an `ObjectSource` read from files), and why each
    other file cannot be used (one line naming it), both in file order, with a progress bar.
    The objects are read (a bare mesh decomposed on first use) on the executor ``parallel``
    describes; the result does not depend on it.

    Raises:
        TasksFailed: reading an object raised something other than a refusal (ValueError,
            OSError), e.g. ModuleNotFoundError for a bare mesh without CoACD installed.
    """
    results: dict[int, ObjectReport | str] = {}
    failed: dict[int, Failure] = {}
    with open_executor(parallel) as executor:
        job = Job(_inspect_task, _setup, (source,))
        for index, result in executor.map(job, range(len(source.files)), "objects"):
            if isinstance(result, Failure):
                failed[index] = result
            else:
                results[index] = result
    if failed:
        index = min(failed)
        raise TasksFailed(
            f"{len(failed)} of {len(source.files)} objects could not be inspected; the first, "
            f"{source.files[index]}: {failed[index].error}"
        )
    ordered = [results[index] for index in sorted(results)]
    reports = [r for r in ordered if isinstance(r, ObjectReport)]
    return reports, [r for r in ordered if isinstance(r, str)]


# -- the task and its worker-side state -----------------------------------------------------

_WORKER: dict[str, ObjectSource] = {}


def _setup(source: ObjectSource) -> None:
    _WORKER["source"] = source


def _inspect_task(index: int) -> ObjectReport | str:
    """Object ``index``'s report, or why it is refused (one line naming the file)."""
    source = _WORKER["source"]
    path = source.files[index]
    try:
        obj = source.load(index)
    except (ValueError, OSError) as error:
        return str(error)
    size = np.ptp(np.concatenate([p.vertices for p in obj.parts]), axis=0)
    if path.suffix == ".urdf":
        units = "mm?" if size.max() > MILLIMETRE_HINT else "m"
        watertight = _visual_watertight(path)
    else:
        units, watertight = _bare_mesh(path, source.mesh_unit)
    return ObjectReport(
        obj.name, units, tuple(float(s) * 1e3 for s in size), obj.mass, len(obj.parts),
        watertight, obj,
    )  # fmt: skip


def contact_sheet(objects: Sequence[ObjectSpec], path: str | Path) -> Path:
    """Draw ``objects`` (their convex parts, each its own colour) into one picture at
    ``path``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    count = max(1, len(objects))
    columns = min(8, count)
    rows = math.ceil(count / columns)
    figure = plt.figure(figsize=(2.2 * columns, 2.4 * rows))
    colours = plt.get_cmap("tab20")
    for k, obj in enumerate(objects):
        ax = figure.add_subplot(rows, columns, k + 1, projection="3d")
        for j, part in enumerate(obj.parts):
            mesh = part.mesh()
            ax.add_collection3d(
                Poly3DCollection(
                    mesh.vertices[mesh.faces],
                    facecolors=[colours(j % 20)],
                    linewidth=0,
                    shade=True,
                )
            )
        vertices = np.concatenate([p.vertices for p in obj.parts])
        centre, half = vertices.mean(axis=0), np.ptp(vertices, axis=0).max() / 2
        ax.set(
            xlim=centre[0] + [-half, half],
            ylim=centre[1] + [-half, half],
            zlim=centre[2] + [-half, half],
        )
        ax.set_axis_off()
        ax.set_title(f"{obj.name[:22]}\n{len(obj.parts)} parts", fontsize=7)
    figure.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=80, format="png")  # the path given, whatever its suffix
    plt.close(figure)
    return path
