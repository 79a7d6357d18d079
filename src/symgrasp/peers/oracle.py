"""The oracle planner: the training labels of the scene as it now lies, the upper bound every
detector is read against (issue 36).

In each declutter state it reads the simulator (``Observation.world``: which objects are on
the table and their poses), takes each object's grasp database (`symgrasp.data.grasp_db`,
cached, built on first use), moves the held grasps by the object's pose, scores them along
world gravity and drops those whose open hand hits the table or any object, exactly as a
training scene is labelled (`symgrasp.data.scenes.scene_grasps`); grasps whose TCP lies outside
the 40³ workspace are dropped too, as `symgrasp.data.labels.voxelise` drops them. What remains
is returned best score first. A detector that predicted its labels perfectly would see these
grasps; the benchmark then plays them as any planner's (checked against the observed surface,
executed, failures diagnosed).

The cost is the databases: every object a round draws is a new one (a mesh set's objects are
scaled per draw, `symgrasp.objects.sets.VGN_SCALE`), ≈ 0.35 s per held grasp on the 2-core
development machine (docs/data.md), so ``grasps`` sets the price of a round. The defaults are
the databases the shipped models were trained on (`symgrasp.config.TRAINING_DATABASE`).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import stat
from pathlib import Path

import numpy as np

from symgrasp.config import TRAINING_DATABASE, DatabaseConfig, SceneConfig
from symgrasp.data.grasp_db import GraspDatabase, cached_database, database_path
from symgrasp.data.labels import voxel_of
from symgrasp.data.scenes import scene_grasps
from symgrasp.detect.grasp import Grasp
from symgrasp.detect.planner import Observation
from symgrasp.names import ORACLE, ORACLE_GRIPPER
from symgrasp.objects.folder import data_folder, user_folder
from symgrasp.sim.grippers import GripperSpec, get_gripper
from symgrasp.sim.objects import ObjectSpec
from symgrasp.workspace import RESOLUTION

CACHE = Path("cache") / "grasp_db"
"""Where the oracle's databases are cached, under the data folder, else the per-user folder."""


def cache_folder() -> Path:
    """The first of ``<data folder>/cache/grasp_db`` and ``<user folder>/cache/grasp_db`` that
    may be written (`writable`), made if missing: the data folder may be read-only."""
    for folder in dict.fromkeys((data_folder() / CACHE, user_folder() / CACHE)):
        if writable(folder):
            folder.mkdir(parents=True, exist_ok=True)
            return folder
    raise ValueError(
        f"no grasp database cache can be written at {data_folder() / CACHE} or "
        f"{user_folder() / CACHE}; name one (cache=…)"
    )


def writable(folder: Path) -> bool:
    """Whether ``folder``, or its nearest existing ancestor where it is to be made, may be
    written: by this process (`os.access`) and by its owner's mode bits, so that a folder
    marked read-only stays so for root too, whom `os.access` never refuses."""
    existing = next(p for p in (folder, *folder.parents) if p.exists())
    return os.access(existing, os.W_OK) and bool(existing.stat().st_mode & stat.S_IWUSR)


class OraclePlanner:
    """The oracle (module docstring) as a `symgrasp.detect.planner.GraspPlanner`.

    Args:
        gripper: the hand (a `GripperSpec` or a built-in's name; default `ORACLE_GRIPPER`).
        grasps: held grasps per object database (`DatabaseConfig.grasps`; default the
            training data's, `symgrasp.config.TRAINING_DATABASE`).
        directions: disturbance directions K of the score (`DatabaseConfig.directions`).
        cache: folder of the databases (default `cache_folder`); not part of what the oracle
            is, so not recorded in its ``version`` (the SHA-256 of its database configuration,
            clearance, surface spacing and seed: a benchmark resumed with other databases is
            refused).
        seed: seed of each database's sampling and of the surface samples of the collision
            check.
    """

    name = ORACLE

    def __init__(
        self,
        gripper: GripperSpec | str = ORACLE_GRIPPER,
        *,
        grasps: int = TRAINING_DATABASE.grasps,
        directions: int = TRAINING_DATABASE.directions,
        cache: str | Path | None = None,
        seed: int = 0,
    ) -> None:
        self.gripper = gripper if isinstance(gripper, GripperSpec) else get_gripper(gripper)
        self.database = DatabaseConfig(grasps=int(grasps), directions=int(directions))
        self.labelling = SceneConfig(database=self.database)
        self.cache = None if cache is None else Path(cache)
        self.seed = int(seed)
        record = {
            "database": dataclasses.asdict(self.database),
            "clearance": self.labelling.clearance,
            "surface_spacing": self.labelling.surface_spacing,
            "seed": self.seed,
        }
        self.version = hashlib.sha256(json.dumps(record, sort_keys=True).encode()).hexdigest()
        self._databases: dict[Path, GraspDatabase] = {}

    def __repr__(self) -> str:
        return (
            f"OraclePlanner(gripper={self.gripper.name!r}, grasps={self.database.grasps}, "
            f"directions={self.database.directions})"
        )

    def database_of(self, obj: ObjectSpec) -> GraspDatabase:
        """``obj``'s database for the hand: from memory, the cache, or built now."""
        folder = self.cache or cache_folder()
        path = database_path(folder, obj, self.gripper, self.database, self.seed)
        if path not in self._databases:
            self._databases[path] = cached_database(
                obj, self.gripper, folder, self.database, self.seed
            )
        return self._databases[path]

    def plan(self, observation: Observation) -> list[Grasp]:
        """The collision-free database grasps of the objects on the table now, best score
        first. ValueError without ``observation.world``: the oracle reads the simulator."""
        world = observation.world
        if world is None:
            raise ValueError(
                "the oracle planner reads the simulator's state (Observation.world) and has "
                "none here: it plays only in the simulated benchmark (symgrasp bench declutter "
                "--model oracle), not on a robot or on depth images"
            )
        objects = list(world.objects)
        grasps = scene_grasps(
            objects,
            world.object_poses(),
            [self.database_of(obj) for obj in objects],
            self.labelling,
            self.gripper,
            np.random.default_rng(self.seed),
        )
        T, score = grasps["T_world_tcp"], grasps["score"]
        index = voxel_of(T[:, :3, 3]).reshape(-1, 3)
        kept = ~grasps["collides"] & np.all((index >= 0) & (index < RESOLUTION), axis=1)
        order = np.flatnonzero(kept)
        order = order[np.argsort(-score[order], kind="stable")]
        return [Grasp(T[g], float(score[g])) for g in order]
