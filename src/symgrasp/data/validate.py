"""Physics check of the labels: the grasps the network is taught must succeed far more often
than random ones.

Each trial draws one labelled voxel uniformly among all the valid voxels of the scenes (as
stored in their files, whatever ``label_spread`` made them), rebuilds its scene (the objects
at their settled poses) and runs :func:`symgrasp.sim.execute_grasp` once with the grasp the
voxel teaches (`symgrasp.data.labels.voxel_grasp`: the TCP at the voxel's centre, one of its
rotation targets, as the detector executes it) and once, in a fresh copy of the same scene,
with a random grasp: TCP at a random surface point of a random object, uniformly random
rotation. The voxels that hold none of the scene's stored grasps' TCPs are those a spread
added (`symgrasp.data.labels.added_voxels`); their trials are counted apart as well.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation
from tqdm import tqdm

from symgrasp.config import SceneConfig
from symgrasp.data.dataset import load_scene, scene_path
from symgrasp.data.labels import added_voxels, voxel_grasp
from symgrasp.data.scenes import scene_pool
from symgrasp.rates import wilson
from symgrasp.sim import World, execute_grasp
from symgrasp.sim.grippers import GripperSpec
from symgrasp.sim.objects import surface_samples


@dataclass(frozen=True)
class ValidationResult:
    """Success rates of ``trials`` labelled voxels' grasps and ``trials`` random grasps, with
    Wilson 95 % intervals (fractions; a rate and its interval are None without trials).

    Attributes:
        trials: trials run (each: one labelled and one random grasp in the same scene).
        labelled_success: share of the labelled voxels' grasps that held.
        random_success: share of the random grasps that held.
        labelled_ci95, random_ci95: their Wilson 95 % intervals.
        added_trials: the trials whose voxel a spread added (no stored grasp's TCP in it);
            0 for a dataset without spread.
        added_success: the share of those that held.
        added_ci95: its Wilson 95 % interval.
    """

    trials: int
    labelled_success: float | None
    random_success: float | None
    labelled_ci95: tuple[float, float] | None
    random_ci95: tuple[float, float] | None
    added_trials: int
    added_success: float | None
    added_ci95: tuple[float, float] | None


def rate(k: int, n: int) -> tuple[float | None, tuple[float, float] | None]:
    """The rate ``k / n`` and its Wilson 95 % interval; None for both without trials."""
    return (k / n, wilson(k, n)) if n else (None, None)


def validate_labels(
    root: str | Path,
    cfg: SceneConfig,
    gripper: GripperSpec,
    scene_ids: list[int],
    trials: int,
    seed: int = 0,
) -> ValidationResult:
    """Run ``trials`` labelled voxels' grasps (drawn uniformly, with replacement, among the
    valid voxels of the scenes ``scene_ids`` of the dataset ``root``) and as many random
    grasps, each in its voxel's scene, with ``gripper`` (the dataset's, as its manifest holds
    it). Without any valid voxel, no trial runs."""
    if trials < 1 or not scene_ids:
        raise ValueError("trials must be ≥ 1 and scene_ids non-empty")
    rng = np.random.default_rng(seed)
    paths = [scene_path(root, int(i)) for i in scene_ids]
    counts = np.array([len(load_scene(p, ("voxel_index",))["voxel_index"]) for p in paths])
    if counts.sum() == 0:
        return ValidationResult(0, None, None, None, None, 0, None, None)
    pool = scene_pool(cfg).objects
    labelled = random = added = added_held = 0
    for _ in tqdm(range(trials), desc="label validation", unit="trial"):
        record = load_scene(paths[int(rng.choice(len(paths), p=counts / counts.sum()))])
        v = int(rng.integers(len(record["voxel_index"])))
        T = voxel_grasp(
            record["voxel_index"][v],
            record["voxel_rotations"][v],
            record["voxel_rotation_mask"][v],
            rng,
        )
        objects = [pool[k] for k in record["object_pool_index"]]
        poses = record["object_poses"]
        held = execute_grasp(World(objects, poses, gripper=gripper), T).success
        labelled += held
        if added_voxels(record["voxel_index"][v : v + 1], record["grasp_pose"])[0]:
            added += 1
            added_held += held
        i = int(rng.integers(len(objects)))
        p, _ = surface_samples(objects[i], 16, rng)
        T = np.eye(4)
        T[:3, :3] = Rotation.random(random_state=int(rng.integers(2**31))).as_matrix()
        T[:3, 3] = poses[i][:3, :3] @ p[0] + poses[i][:3, 3]
        random += execute_grasp(World(objects, poses, gripper=gripper), T).success
    labelled_rate, labelled_ci = rate(labelled, trials)
    random_rate, random_ci = rate(random, trials)
    return ValidationResult(
        trials, labelled_rate, random_rate, labelled_ci, random_ci, added, *rate(added_held, added)
    )
