"""One labelled cluttered scene: objects, surviving grasps, voxel labels and one depth view.

:func:`make_scene_record` is a pure task of ``(scene_id, config, hand, pool, databases)``: the
same inputs give the same record, so scenes can be generated in any order, by any number of
processes or by a cluster engine. The configuration's names are resolved once per process:
the gripper by the caller (`symgrasp.sim.grippers.get_gripper`), the object set and its pool by
`scene_pool`. Steps:

1. draw the scene kind (``pile``/``packed``) and ``N ~ Poisson(mean) + 1`` objects from the
   object pool; build and settle the scene (:mod:`symgrasp.sim.world`);
2. move every object's held database grasps by its settled pose; read each grasp's
   gravity-rejection score along world −z (expressed in the object frame);
3. drop grasps whose open hand hits the table or any object at the grasp or on the approach
   from the pre-grasp (:func:`symgrasp.sim.collision.hand_collides`);
4. voxelise the survivors (:func:`symgrasp.data.labels.voxelise`), each also at the voxel
   centres its tolerance ``cfg.label_spread`` reaches where the open hand is free as well
   (:func:`spread_labels`; by default none: a grasp labels the voxel of its TCP alone);
5. render one depth image from a random camera on a spherical cap around the workspace, add
   the configuration's depth noise (``cfg.noise``, `symgrasp.perception.noise.noisy_depth`:
   the benchmark's function, drawn from the scene's own noise stream, `noise_seed`) and fuse
   it into the 40³ TSDF.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from symgrasp.config import SceneConfig
from symgrasp.data.grasp_db import GraspDatabase, OnDemandDatabase
from symgrasp.data.labels import VoxelLabels, spread_poses, voxelise
from symgrasp.objects.sets import ObjectSource, resolve
from symgrasp.perception import CameraIntrinsic, TSDFVolume, noisy_depth, orbit_extrinsic
from symgrasp.perception.table import table_scaled
from symgrasp.sim.collision import hand_collides
from symgrasp.sim.grippers import GripperSpec
from symgrasp.sim.objects import ObjectSpec, surface_samples
from symgrasp.sim.render import make_renderer
from symgrasp.sim.world import World
from symgrasp.workspace import RESOLUTION, TABLE_HEIGHT, WORKSPACE_SIZE

DEPTH_UNIT = 1e-4
"""Depth images are stored as uint16 in units of 0.1 mm (up to 6.5 m)."""


@dataclass(frozen=True)
class ScenePool:
    """The objects of a dataset's scenes: the object set's ``source``, which builds the scenes,
    and the ``objects`` they are drawn from, ``objects[k]`` the one of grasp database ``k``."""

    source: ObjectSource
    objects: tuple[ObjectSpec, ...]


def scene_pool(cfg: SceneConfig) -> ScenePool:
    """The pool of ``cfg``: its object set resolved (`symgrasp.objects.sets.resolve`, bare meshes
    read in ``mesh_unit`` and cut by ``decomposition``) and ``pool_size`` of its objects drawn
    from ``pool_seed`` (`ObjectSource.pool`). Made once per process, shared by its scenes and
    databases."""
    source = resolve(cfg.object_set, cfg.mesh_unit, cfg.decomposition)
    return ScenePool(source, tuple(source.pool(cfg.pool_size, cfg.pool_seed)))


def scene_rng(seed: int, scene_id: int) -> np.random.Generator:
    """The random stream of one scene: independent of every other scene id."""
    return np.random.default_rng([seed, scene_id])


NOISE_STREAM = 0x6E6F6973
"""Last word of the seed of a scene's depth noise (`noise_seed`): ASCII "nois". Nonzero, since
NumPy's seeding ignores trailing zeros (``[s, i, 0]`` is `scene_rng`'s ``[s, i]``), and larger
than any attempt index of the benchmark's draws (`symgrasp.benchmark.sensing.draw_seed`), so
neither the scene's stream nor a benchmark's draw starts from the same seed."""


def noise_seed(seed: int, scene_id: int) -> tuple[int, int, int]:
    """The seed of scene ``scene_id``'s depth noise in the dataset of seed ``seed``: a stream of
    its own beside `scene_rng`'s, so adding noise draws nothing from the scene's stream (its
    objects, labels and camera stay those of the noiseless scene) and depends on nothing but the
    scene."""
    return (seed, scene_id, NOISE_STREAM)


def random_camera(cfg: SceneConfig, rng: np.random.Generator) -> np.ndarray:
    """``T_world_camera`` on a spherical cap above the workspace, looking at its centre."""
    r = rng.uniform(*cfg.camera_distance)
    polar = rng.uniform(*cfg.camera_polar)
    azimuth = rng.uniform(0, 2 * np.pi)
    return orbit_extrinsic(np.full(3, WORKSPACE_SIZE / 2), r, polar, azimuth)


def scene_grasps(
    objects: list[ObjectSpec],
    poses: np.ndarray,
    databases: list[GraspDatabase] | list[OnDemandDatabase],
    cfg: SceneConfig,
    hand: GripperSpec,
    rng: np.random.Generator,
) -> dict[str, np.ndarray]:
    """Every held database grasp moved into the scene, with its score along world gravity,
    and whether the open ``hand`` collides there (``collides``): arrays over all G grasps; and
    the scene's surface samples that the check used (``points``, (P, 3) world frame).

    The scores are read after the collision check, naming the grasps it keeps: an
    `OnDemandDatabase` measures only those (the others' scores may then be NaN)."""
    T, width, owner = [], [], []
    for i, (T_wo, db) in enumerate(zip(poses, databases, strict=True)):
        held = db.held
        T.append(T_wo @ db.T_object_tcp[held])
        width.append(db.width[held])
        owner.append(np.full(int(held.sum()), i))
    T_all = np.concatenate(T).reshape(-1, 4, 4) if T else np.zeros((0, 4, 4))
    cloud = scene_points(objects, poses, cfg, rng)
    owner_all = np.concatenate(owner) if owner else np.zeros(0, dtype=int)
    collides = hand_collides(T_all, hand, cloud, tolerance=-cfg.clearance)
    score = [
        db.score_along(
            T_wo[:3, :3].T @ np.array([0.0, 0.0, -1.0]),  # world gravity in the object frame
            np.flatnonzero(~collides[owner_all == i]),
        )
        for i, (T_wo, db) in enumerate(zip(poses, databases, strict=True))
    ]
    return {
        "T_world_tcp": T_all,
        "score": np.concatenate(score) if score else np.zeros(0),
        "width": np.concatenate(width) if width else np.zeros(0),
        "object": owner_all,
        "collides": collides,
        "points": cloud,
    }


def scene_points(
    objects: list[ObjectSpec], poses: np.ndarray, cfg: SceneConfig, rng: np.random.Generator
) -> np.ndarray:
    """The scene's surface samples (P, 3) in the world frame, which the labels' collision
    check tests the open hand against: ``cfg.surface_spacing`` apart on each object (at least
    64), drawn from ``rng`` object by object."""
    points = []
    for obj, T_wo in zip(objects, poses, strict=True):
        area = float(obj.mesh().area)
        p, _ = surface_samples(obj, max(64, int(area / cfg.surface_spacing**2)), rng)
        points.append(p @ T_wo[:3, :3].T + T_wo[:3, 3])
    return np.concatenate(points) if points else np.zeros((0, 3))


def spread_box(cfg: SceneConfig) -> tuple[np.ndarray, np.ndarray]:
    """The tolerance box of ``cfg.label_spread`` in the grasp frame: its lower and upper
    corners (3,) [m] along e_x, e_y, e_z."""
    back, forward, y, z = cfg.label_spread
    return np.array([-back, -y, -z]), np.array([forward, y, z])


def spread_labels(
    T_world_tcp: np.ndarray,
    score: np.ndarray,
    width: np.ndarray,
    cfg: SceneConfig,
    collides: Callable[[np.ndarray], np.ndarray],
) -> VoxelLabels:
    """The voxel labels of the surviving grasps ``T_world_tcp`` (G, 4, 4) with ``score`` and
    ``width`` (G,): each grasp labels the voxel of its TCP and, with its rotation, score and
    width, every other voxel centre of its tolerance box (`spread_box`, `spread_poses`) where
    ``collides`` ((N, 4, 4) poses → (N,) bool: the scene's swept-hand check) says the hand is
    free. Voxels merge as in `voxelise` (best score, up to ``cfg.k_max`` rotations). With
    ``cfg.label_spread`` all zero, exactly ``voxelise`` of the grasps."""
    if not any(cfg.label_spread):
        return voxelise(T_world_tcp, score, width, cfg.k_max)
    moved, source = spread_poses(T_world_tcp, *spread_box(cfg))
    free = ~collides(moved) if len(moved) else np.zeros(0, dtype=bool)
    keep = source[free]
    return voxelise(
        np.concatenate([T_world_tcp.reshape(-1, 4, 4), moved[free]]),
        np.concatenate([score, score[keep]]),
        np.concatenate([width, width[keep]]),
        cfg.k_max,
    )


@dataclass(frozen=True)
class LabelledScene:
    """A settled scene and its labels, before it is observed (`labelled_scene`).

    Attributes:
        kind: "pile" or "packed".
        world: the settled scene (no hand).
        pool_index: (N,) pool index of each kept object, in the world's order.
        poses: (N, 4, 4) their settled ``T_world_object``.
        grasps: `scene_grasps` of the kept objects (every held database grasp, collisions).
        labels: the voxel labels of the grasps that survive the collision check.
    """

    kind: str
    world: World
    pool_index: np.ndarray
    poses: np.ndarray
    grasps: dict[str, np.ndarray]
    labels: VoxelLabels

    @property
    def survivors(self) -> np.ndarray:
        """(G,) bool: the grasps that pass the collision check."""
        return ~self.grasps["collides"]


def scene_draws(
    scene_id: int, cfg: SceneConfig, seed: int = 0
) -> tuple[np.random.Generator, str, list[int], int]:
    """Step 1's draws of scene ``scene_id``: its random stream (`scene_rng`) after them, the
    kind, the pool indices of the objects dropped and the seed the scene is built and settled
    with. The stream goes on to `scene_points`, then the observation."""
    rng = scene_rng(seed, scene_id)
    kind = str(rng.choice(cfg.kinds))
    n = min(int(rng.poisson(cfg.mean_objects)) + 1, cfg.max_objects)
    chosen = [int(k) for k in rng.integers(cfg.pool_size, size=n)]
    return rng, kind, chosen, int(rng.integers(2**31))


def labelled_scene(
    scene_id: int,
    cfg: SceneConfig,
    hand: GripperSpec,
    pool: ScenePool,
    databases: list[GraspDatabase],
    seed: int = 0,
) -> tuple[LabelledScene, np.random.Generator]:
    """Steps 1–4 of scene ``scene_id`` (see `make_scene_record` for the arguments), and the
    scene's random stream, from which the observation goes on drawing."""
    rng, kind, chosen, world_seed = scene_draws(scene_id, cfg, seed)
    specs = [pool.objects[k] for k in chosen]
    world = pool.source.scene(kind, specs, seed=world_seed)
    kept = [next(j for j, s in enumerate(specs) if s is o) for o in world.objects]
    pool_index = np.array([chosen[j] for j in kept], dtype=np.int64)
    poses = world.object_poses()

    placed = [databases[k] for k in pool_index]  # the settled objects' databases
    grasps = scene_grasps(world.objects, poses, placed, cfg, hand, rng)
    ok = ~grasps["collides"]
    labels = spread_labels(
        grasps["T_world_tcp"][ok],
        grasps["score"][ok],
        grasps["width"][ok],
        cfg,
        lambda T: hand_collides(T, hand, grasps["points"], tolerance=-cfg.clearance),
    )
    return LabelledScene(kind, world, pool_index, poses, grasps, labels), rng


def label_arrays(labels: VoxelLabels) -> dict[str, np.ndarray]:
    """The arrays of a scene file that hold its voxel labels, in the file's types."""
    return {
        "voxel_index": labels.voxel_index.astype(np.int16),
        "voxel_score": labels.score,
        "voxel_width": labels.width,
        "voxel_rotations": labels.rotations,
        "voxel_rotation_mask": labels.mask,
        "rotations_dropped": np.int64(labels.dropped),
    }


def make_scene_record(
    scene_id: int,
    cfg: SceneConfig,
    hand: GripperSpec,
    pool: ScenePool,
    databases: list[GraspDatabase],
    seed: int = 0,
) -> dict[str, np.ndarray]:
    """Build, label and observe scene ``scene_id`` of ``cfg`` for the gripper ``hand`` (the spec
    of ``cfg.gripper``); ``databases[k]`` belongs to ``pool.objects[k]`` (``pool`` =
    `scene_pool` of ``cfg``). Returns the arrays stored in the scene's file (docs/data.md).
    ``depth`` is the rendered image, before the noise: the image fused is
    ``noisy_depth(depth, cfg.noise, noise_seed(seed, scene_id))`` (divided by its table's
    depth scale where ``cfg.table_scale``), reproduced from the stored
    one to its 0.1 mm steps (a noisy image, stored, would compress to several times the file:
    docs/data.md, "Depth noise")."""
    scene, rng = labelled_scene(scene_id, cfg, hand, pool, databases, seed)
    grasps, ok, labels = scene.grasps, scene.survivors, scene.labels

    intrinsic = CameraIntrinsic()
    T_world_camera = random_camera(cfg, rng)
    depth = make_renderer(intrinsic).render(scene.world, T_world_camera)
    seen = noisy_depth(depth, cfg.noise, noise_seed(seed, scene_id))
    if cfg.table_scale:
        seen = table_scaled(seen[None], intrinsic, T_world_camera[None], TABLE_HEIGHT)[0]
    volume = TSDFVolume(resolution=RESOLUTION)
    volume.integrate(seen, intrinsic, T_world_camera)

    return {
        "scene_id": np.int64(scene_id),
        "kind": np.str_(scene.kind),
        "object_pool_index": scene.pool_index,
        "object_poses": scene.poses.astype(np.float64),
        "grasp_pose": grasps["T_world_tcp"][ok].astype(np.float32),
        "grasp_score": grasps["score"][ok].astype(np.float32),
        "grasp_width": grasps["width"][ok].astype(np.float32),
        "grasp_object": grasps["object"][ok].astype(np.int64),
        "grasps_total": np.int64(len(ok)),
        **label_arrays(labels),
        "tsdf": volume.grid().numpy().astype(np.float16),
        "depth": np.round(depth / DEPTH_UNIT).astype(np.uint16),
        "intrinsic": np.array(
            [
                intrinsic.width,
                intrinsic.height,
                intrinsic.fx,
                intrinsic.fy,
                intrinsic.cx,
                intrinsic.cy,
            ]
        ),
        "extrinsic": T_world_camera,
    }
