"""The oracle planner: the training labels of the scene as it now lies, the upper bound every
detector is read against (issue 36).

In each declutter state it reads the simulator (``Observation.world``: which objects are on
the table and their poses), takes each object's grasp database (`symgrasp.data.grasp_db`,
built on first use), moves the held grasps by the object's pose, scores them along
world gravity and drops those whose open hand hits the table or any object, exactly as a
training scene is labelled (`symgrasp.data.scenes.scene_grasps`); grasps whose TCP lies outside
the 40³ workspace are dropped too, as `symgrasp.data.labels.voxelise` drops them. What remains
is returned best score first. A detector that predicted its labels perfectly would see these
grasps; the benchmark then plays them as any planner's (checked against the observed surface,
executed, failures diagnosed).

The cost is the databases: every object a round draws is a new one (a mesh set's objects are
scaled per draw, `symgrasp.objects.sets.VGN_SCALE`), so they are `OnDemandDatabase`s kept in
memory: closed at once, each grasp scored only along the directions a state reads and only once
it survives the collision check, the same scores `build_database` gives, bit for bit
(docs/reports/grasp-databases.md, "Scoring what is read"); ``grasps`` sets the price of a round.
The defaults are the databases the shipped models were trained on
(`symgrasp.config.TRAINING_DATABASE`).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from collections import OrderedDict

import numpy as np

from symgrasp.config import TRAINING_DATABASE, DatabaseConfig, SceneConfig
from symgrasp.data.grasp_db import OnDemandDatabase, database_key
from symgrasp.data.labels import voxel_of
from symgrasp.data.scenes import scene_grasps
from symgrasp.detect.grasp import Grasp
from symgrasp.detect.planner import Observation
from symgrasp.names import ORACLE, ORACLE_GRIPPER
from symgrasp.sim.grippers import GripperSpec, get_gripper
from symgrasp.sim.objects import ObjectSpec
from symgrasp.workspace import RESOLUTION

HAND = get_gripper(ORACLE_GRIPPER)
"""The oracle's hand when none is given."""

KEEP = 16
"""Databases the oracle keeps in memory (the most recently read): more than a scene's objects,
so the objects of a round are closed once; a new round's objects are new ones."""


class OraclePlanner:
    """The oracle (module docstring) as a `symgrasp.detect.planner.GraspPlanner`.

    Args:
        gripper: the hand (default `HAND`, the built-in `ORACLE_GRIPPER`).
        grasps: held grasps per object database (`DatabaseConfig.grasps`; default the
            training data's, `symgrasp.config.TRAINING_DATABASE`).
        directions: disturbance directions K of the score (`DatabaseConfig.directions`).
        offset: range [m] of the TCP's offset along the approach from the contacts' midpoint
            (`DatabaseConfig.offset`): how the labels a dataset of that range would carry fare.
        seed: seed of each database's sampling and of the surface samples of the collision
            check.

    ``version`` is the SHA-256 of its database configuration, clearance, surface spacing and
    seed: a benchmark resumed with other databases is refused.
    """

    name = ORACLE

    def __init__(
        self,
        gripper: GripperSpec = HAND,
        *,
        grasps: int = TRAINING_DATABASE.grasps,
        directions: int = TRAINING_DATABASE.directions,
        offset: tuple[float, float] = TRAINING_DATABASE.offset,
        seed: int = 0,
    ) -> None:
        self.gripper = gripper
        self.database = DatabaseConfig(
            grasps=int(grasps), directions=int(directions), offset=tuple(map(float, offset))
        )
        self.labelling = SceneConfig(database=self.database)
        self.seed = int(seed)
        record = {
            "database": dataclasses.asdict(self.database),
            "clearance": self.labelling.clearance,
            "surface_spacing": self.labelling.surface_spacing,
            "seed": self.seed,
        }
        self.version = hashlib.sha256(json.dumps(record, sort_keys=True).encode()).hexdigest()
        self._databases: OrderedDict[str, OnDemandDatabase] = OrderedDict()

    def __repr__(self) -> str:
        return (
            f"OraclePlanner(gripper={self.gripper.name!r}, grasps={self.database.grasps}, "
            f"directions={self.database.directions}, offset={self.database.offset})"
        )

    def database_of(self, obj: ObjectSpec) -> OnDemandDatabase:
        """``obj``'s database for the hand, closed on first use and scored as read."""
        key = database_key(obj, self.gripper, self.database, self.seed)
        if key not in self._databases:
            self._databases[key] = OnDemandDatabase(obj, self.gripper, self.database, self.seed)
            while len(self._databases) > KEEP:
                self._databases.popitem(last=False)
        self._databases.move_to_end(key)
        return self._databases[key]

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
