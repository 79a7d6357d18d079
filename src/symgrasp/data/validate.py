"""Physics check of the labels: labelled grasps must succeed far more often than random ones.

Each trial rebuilds a stored scene (its objects at their settled poses) and runs
:func:`symgrasp.sim.execute_grasp` once with a random surviving labelled grasp and once,
in a fresh copy, with a random grasp: TCP at a random surface point of a random object,
uniformly random rotation.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation
from tqdm import tqdm

from symgrasp.config import SceneConfig
from symgrasp.data.dataset import load_scene, scene_path
from symgrasp.data.scenes import scene_pool
from symgrasp.sim import World, execute_grasp
from symgrasp.sim.grippers import GripperSpec
from symgrasp.sim.objects import surface_samples


@dataclass(frozen=True)
class ValidationResult:
    """Success rates of ``trials`` labelled and ``trials`` random grasps."""

    trials: int
    labelled_success: float
    random_success: float


def validate_labels(
    root: str | Path,
    cfg: SceneConfig,
    gripper: GripperSpec,
    scene_ids: list[int],
    trials: int,
    seed: int = 0,
) -> ValidationResult:
    """Run ``trials`` labelled and random grasps with ``gripper`` (the dataset's, as its
    manifest holds it) on scenes drawn from ``scene_ids``."""
    if trials < 1 or not scene_ids:
        raise ValueError("trials must be ≥ 1 and scene_ids non-empty")
    rng = np.random.default_rng(seed)
    pool = scene_pool(cfg).objects
    labelled = random = done = 0
    for _ in tqdm(range(trials), desc="label validation", unit="trial"):
        record = load_scene(scene_path(root, int(rng.choice(scene_ids))))
        if len(record["grasp_pose"]) == 0:
            continue
        objects = [pool[k] for k in record["object_pool_index"]]
        poses = record["object_poses"]
        g = int(rng.integers(len(record["grasp_pose"])))
        world = World(objects, poses, gripper=gripper)
        labelled += execute_grasp(world, record["grasp_pose"][g].astype(float)).success
        i = int(rng.integers(len(objects)))
        p, _ = surface_samples(objects[i], 16, rng)
        T = np.eye(4)
        T[:3, :3] = Rotation.random(random_state=int(rng.integers(2**31))).as_matrix()
        T[:3, 3] = poses[i][:3, :3] @ p[0] + poses[i][:3, 3]
        world = World(objects, poses, gripper=gripper)
        random += execute_grasp(world, T).success
        done += 1
    return ValidationResult(done, labelled / max(done, 1), random / max(done, 1))
