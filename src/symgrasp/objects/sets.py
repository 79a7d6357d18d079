"""An object set resolved once, at the edge: a procedural set's name, one of VGN's mesh sets,
a folder of URDF files or of bare meshes (`symgrasp.objects.mesh`), or several mesh sets and
folders joined by commas (``vgn-pile-train,vgn-packed-train``: the union of their objects).
Every command that takes ``--objects`` resolves it here.

A folder holding a URDF file is a folder of URDF objects, and its other files are theirs (VGN's
folders hold each object's collision and visual OBJ beside its URDF); a folder without one is
a folder of bare meshes (`symgrasp.objects.mesh.mesh_files`).

A set gives the objects of a scene (`ObjectSource.draw`) and a training pool
(`ObjectSource.pool`), and builds the scenes its objects belong in (`ObjectSource.scene`):
procedural sets keep symgrasp's own pile and packed builders (so every result published on
them reproduces), mesh sets are drawn and placed as VGN's simulator does (Breyer et al., CoRL
2020): objects drawn uniformly with replacement, scaled by U(0.8, 1.0) in a pile and
U(0.7, 0.9) in a packed scene.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from symgrasp.names import (
    DECOMPOSITIONS,
    MESH_OBJECT_SETS,
    MESH_UNITS,
    PROCEDURAL_OBJECT_SETS,
    SCENES,
)
from symgrasp.objects.folder import data_folder, set_folder
from symgrasp.sim.objects import ObjectSpec, object_set
from symgrasp.workspace import WORKSPACE_SIZE

if TYPE_CHECKING:
    from symgrasp.sim.grippers import GripperSpec
    from symgrasp.sim.world import World

VGN_SCALE = {"pile": (0.8, 1.0), "packed": (0.7, 0.9)}
"""The scale VGN draws for each object of a scene, by scene kind."""

POOL_SCALE = (0.7, 1.0)
"""The scale drawn once per object of a mesh set's training pool: both scene kinds' ranges.
A pool object keeps one scale, because its grasp database is built at that scale."""

_MESH_STREAM = 1000  # random streams of mesh sets, apart from the procedural sets' 0..3


@dataclass(frozen=True)
class ObjectSource:
    """Where a scene's objects come from: ``name`` (a procedural set, no ``folders``) or the
    URDF files or bare meshes of ``folders``, bare meshes read in ``mesh_unit`` (one of
    `MESH_UNITS`) and cut into convex parts by the preset ``decomposition``
    (`symgrasp.objects.decomposition.PRESETS`)."""

    name: str
    folders: tuple[Path, ...] = ()
    mesh_unit: str = "auto"
    decomposition: str = DECOMPOSITIONS[0]

    @property
    def meshes(self) -> bool:
        """Whether the objects are read from files (else built in code)."""
        return bool(self.folders)

    @functools.cached_property
    def files(self) -> tuple[Path, ...]:
        """The object files of a mesh set (`folder_files`), in folder order."""
        return tuple(path for folder in self.folders for path in folder_files(folder))

    def load(self, index: int) -> ObjectSpec:
        """Object ``index`` of a mesh set, unscaled."""
        path = self.files[index]
        return _load(path, self.mesh_unit, path.parent not in self.folders, self.decomposition)

    def check(self) -> None:
        """Read every object of a mesh set once (`load`), so that a broken file or an object
        larger than the workspace is refused now, naming the file, and not in the first round
        or scene that draws it (a training pool reads every object anyway)."""
        for index in range(len(self.files)):
            self.load(index)

    def draw(self, n: int, seed: int, scene: str = "pile") -> list[ObjectSpec]:
        """The ``n`` objects of round/scene ``seed`` for a ``scene`` of that kind."""
        if scene not in SCENES:
            raise ValueError(f"scene must be one of {SCENES}, got {scene!r}")
        if not self.meshes:
            return object_set(self.name, n, seed)
        rng = np.random.default_rng([seed, _MESH_STREAM])
        chosen = rng.integers(len(self.files), size=n)
        scales = rng.uniform(*VGN_SCALE[scene], size=n)
        return [self.load(int(k)).scaled(float(s)) for k, s in zip(chosen, scales, strict=True)]

    def pool(self, size: int, seed: int) -> list[ObjectSpec]:
        """``size`` objects to build grasp databases for: a procedural set's draw, or a mesh
        set's objects in a random order (again from the start when ``size`` exceeds the set),
        each scaled once by U`POOL_SCALE`."""
        if not self.meshes:
            return object_set(self.name, size, seed)
        rng = np.random.default_rng([seed, _MESH_STREAM + 1])
        order = np.concatenate(
            [rng.permutation(len(self.files)) for _ in range(-(-size // len(self.files)))]
        )[:size]
        scales = rng.uniform(*POOL_SCALE, size=size)
        return [self.load(int(k)).scaled(float(s)) for k, s in zip(order, scales, strict=True)]

    def scene(
        self,
        kind: str,
        objects: Sequence[ObjectSpec],
        seed: int,
        gripper: GripperSpec | None = None,
    ) -> World:
        """A settled scene of ``kind`` holding ``objects`` (`symgrasp.sim.world`)."""
        from symgrasp.sim import world

        if kind not in SCENES:
            raise ValueError(f"scene must be one of {SCENES}, got {kind!r}")
        if not self.meshes:
            build = world.pile_scene if kind == "pile" else world.packed_scene
        else:
            build = world.vgn_pile_scene if kind == "pile" else world.vgn_packed_scene
        return build(objects, seed=seed, gripper=gripper)


def folder_files(folder: Path) -> tuple[Path, ...]:
    """The objects of ``folder``: its URDF files sorted by name when it holds one, else its
    bare meshes (`symgrasp.objects.mesh.mesh_files`)."""
    from symgrasp.objects.mesh import mesh_files

    return tuple(sorted(folder.glob("*.urdf"))) or mesh_files(folder)


@functools.lru_cache(maxsize=1024)
def _load(path: Path, mesh_unit: str, in_subfolder: bool, decomposition: str) -> ObjectSpec:
    """The object of a URDF file or bare mesh at ``path`` (one in its own sub-folder is named
    after the sub-folder), refused when longer than the workspace."""
    from symgrasp.objects.mesh import load_mesh
    from symgrasp.objects.urdf import load_urdf

    if path.suffix == ".urdf":
        obj, hint = load_urdf(path), "is the mesh in millimetres?"
    else:
        name = path.parent.name if in_subfolder else None
        obj, hint = load_mesh(path, mesh_unit, name, decomposition), "check its units: --mesh-unit"
    size = np.ptp(obj.hull_points(), axis=0)
    if size.max() > WORKSPACE_SIZE:
        raise ValueError(
            f"{path}: the object is {size.max():.3f} m long, larger than the "
            f"{WORKSPACE_SIZE} m workspace ({hint})"
        )
    return obj


def resolve(
    objects: str | Path, mesh_unit: str = "auto", decomposition: str = DECOMPOSITIONS[0]
) -> ObjectSource:
    """The source named ``objects``: a procedural set, one of VGN's sets (from the data
    folder), a folder holding URDF files or bare meshes (read in ``mesh_unit``, one of
    `MESH_UNITS`, and cut into convex parts by the preset ``decomposition``, one of
    `DECOMPOSITIONS`), or several of the last two joined by commas. Raises ValueError listing
    the known names when a part is none of these (or a procedural set is joined to others), or
    when a part is empty (it would name the current folder), and
    `symgrasp.objects.folder.MissingData` when a named mesh set is not in the data folder."""
    if mesh_unit not in MESH_UNITS:
        raise ValueError(f"mesh_unit must be one of {MESH_UNITS}, got {mesh_unit!r}")
    if decomposition not in DECOMPOSITIONS:
        raise ValueError(
            f"decomposition must be one of {', '.join(DECOMPOSITIONS)}, got {decomposition!r}"
        )
    name = str(objects)
    if name in PROCEDURAL_OBJECT_SETS:
        return ObjectSource(name)
    if not all(part.strip() for part in name.split(",")):
        raise ValueError(
            f"objects holds an empty name (an empty string, or a comma with nothing on one side"
            f" of it), which would read the current folder: {name!r}"
        )
    folders = tuple(_mesh_folder(part) for part in name.split(","))
    if len(set(folders)) < len(folders):
        raise ValueError(f"objects names a set twice: {name!r}")
    for folder in folders:
        if not folder_files(folder):
            raise ValueError(
                f"objects folder {folder} holds no .urdf file, nor any .obj, .stl or .ply mesh"
            )
    return ObjectSource(name, folders, mesh_unit, decomposition)


def unrecorded_decomposition(objects: str) -> str:
    """The decomposition preset a record of the object set ``objects`` (a benchmark's
    ``config.json``, a dataset's manifest) was made with when it predates the field:
    `symgrasp.objects.decomposition.BEFORE_PRESETS` where the set may hold bare meshes (a
    folder without a URDF file, or one no longer there to tell), else the default: the named
    sets are built in code or read from URDF files, whose parts no preset changes, so their
    records reuse as they always did."""
    from symgrasp.objects.decomposition import BEFORE_PRESETS

    named = PROCEDURAL_OBJECT_SETS + MESH_OBJECT_SETS
    folders = [Path(p).expanduser() for p in str(objects).split(",") if p not in named]
    if any(not f.is_dir() or not any(f.glob("*.urdf")) for f in folders):
        return BEFORE_PRESETS
    return DECOMPOSITIONS[0]


def _mesh_folder(part: str) -> Path:
    """The folder of one mesh set's name or a folder path."""
    if part in MESH_OBJECT_SETS:
        return set_folder(part).resolve()
    folder = Path(part).expanduser()
    if not folder.is_dir():
        known = ", ".join(PROCEDURAL_OBJECT_SETS + MESH_OBJECT_SETS)
        joined = " (procedural sets cannot be joined)" if part in PROCEDURAL_OBJECT_SETS else ""
        raise ValueError(
            f"objects must be one of {known} (mesh sets are read from the data folder "
            f"{data_folder()}), a folder of URDF files or meshes, or mesh sets and folders "
            f"joined by commas, got {part!r}{joined}"
        )
    return folder.resolve()


def make_scene(
    scene: str,
    objects: str | Path | ObjectSource | Sequence[ObjectSpec] = "household-train",
    n: int = 5,
    seed: int = 0,
    gripper: GripperSpec | None = None,
) -> World:
    """A settled ``scene`` ("pile" or "packed") of ``n`` objects of the set ``objects`` (a
    name or folder for `resolve`, or a resolved source; or these objects, in a procedural
    scene) drawn with ``seed``, with ``gripper`` parked above it."""
    if scene not in SCENES:
        raise ValueError(f"scene must be one of {SCENES}, got {scene!r}")
    if isinstance(objects, (str, Path, ObjectSource)):
        source = objects if isinstance(objects, ObjectSource) else resolve(objects)
        return source.scene(scene, source.draw(n, seed, scene), seed, gripper)
    return ObjectSource("objects").scene(scene, list(objects), seed, gripper)
