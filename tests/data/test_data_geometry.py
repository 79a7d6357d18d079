"""Directions, the hand collision check and voxel labels, against independent oracles."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from symgrasp.data.directions import fibonacci_directions, interpolate
from symgrasp.data.labels import rotation_angle_up_to_flip, voxelise
from symgrasp.sim import FRANKA, ROBOTIQ_2F85, World, object_set
from symgrasp.sim.collision import hand_collides
from symgrasp.sim.execute import top_grasp
from symgrasp.sim.objects import surface_samples
from symgrasp.workspace import TABLE_HEIGHT, VOXEL_SIZE

FLIP = np.diag([1.0, -1.0, -1.0])


def test_fibonacci_directions_are_unit_and_spread():
    d = fibonacci_directions(32)
    assert np.allclose(np.linalg.norm(d, axis=1), 1.0)
    assert np.linalg.norm(d.mean(axis=0)) < 0.05  # balanced over the sphere
    cos = d @ d.T - 2 * np.eye(32)
    # 32 points on S²: the best packing keeps neighbours ≈ 37° apart; no two within 25°
    assert np.degrees(np.arccos(cos.max())) > 25


def test_interpolation_is_exact_at_stored_directions_and_keeps_constants():
    d = fibonacci_directions(32)
    values = np.random.default_rng(0).random((5, 32))
    assert np.allclose(interpolate(values, d, d[7]), values[:, 7])
    q = np.array([0.3, -0.2, 0.9])
    assert np.allclose(interpolate(np.full((2, 32), 0.4), d, q), 0.4)
    between = interpolate(values, d, q)
    assert np.all(between >= values.min(axis=1)) and np.all(between <= values.max(axis=1))


@pytest.mark.parametrize("gripper", [FRANKA, ROBOTIQ_2F85], ids=lambda g: g.name)
def test_collision_check_agrees_with_mujoco_contacts(gripper):
    """Oracle: MuJoCo's own collision detection on the hand's full model, at random poses."""
    rng = np.random.default_rng(0)
    agree = total = collisions = 0
    for obj in object_set("household-train", 3, seed=1):
        T = np.eye(4)
        T[:3, 3] = (0.15, 0.15, 0.6)  # far above the table
        world = World([obj], T[None], gripper=gripper)
        points = surface_samples(obj, 6000, rng)[0] + T[:3, 3]
        for _ in range(40):
            G = np.eye(4)
            G[:3, :3] = Rotation.random(random_state=int(rng.integers(2**31))).as_matrix()
            G[:3, 3] = T[:3, 3] + rng.normal(0, 0.05, 3)
            world.set_hand_pose(G)
            mj = world.hand_in_collision()
            ours = hand_collides(
                G[None], gripper, points, tolerance=0.0, sweep=0.0, table_height=-1
            )
            agree += mj == ours[0]
            collisions += mj
            total += 1
    assert 0.2 < collisions / total < 0.8  # both cases are exercised
    assert agree / total >= 0.97  # measured 0.99–1.0; disagreements are grazing contacts


def test_collision_check_sees_the_table_and_the_approach_path():
    gripper = FRANKA
    above = top_grasp([0.15, 0.15, TABLE_HEIGHT + 0.03])
    below = top_grasp([0.15, 0.15, TABLE_HEIGHT - 0.01])  # fingertips 9 mm past the TCP
    assert list(hand_collides(np.stack([above, below]), gripper, np.zeros((0, 3)))) == [False, True]
    # a point on a finger's path only: 12 cm behind the TCP (beyond the palm, which ends
    # 10.3 cm behind it) and 4.5 cm along the closing axis (the open pad's centre)
    obstacle = np.array([[0.15 + 0.045, 0.15, TABLE_HEIGHT + 0.03 + 0.12]])
    assert not hand_collides(above[None], gripper, obstacle, sweep=0.0)[0]
    assert hand_collides(above[None], gripper, obstacle)[0]


def _pose(R, p):
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, p
    return T


def test_voxelise_groups_by_tcp_voxel_and_merges_flipped_rotations():
    R = Rotation.from_euler("xyz", [0.3, -0.5, 1.0]).as_matrix()
    R30 = Rotation.from_euler("x", np.radians(30)).as_matrix() @ R
    p = (np.array([3, 17, 9]) + 0.5) * VOXEL_SIZE  # a voxel centre (TSDF convention)
    poses = np.stack(
        [
            _pose(R, p),
            _pose(R @ FLIP, p + 0.003),  # same voxel, the same grasp flipped
            _pose(R30, p - 0.003),  # same voxel, a different rotation
            _pose(R, p + np.array([VOXEL_SIZE, 0, 0])),  # next voxel along x
            _pose(R, [0.31, 0.1, 0.1]),  # outside the workspace
        ]
    )
    score = np.array([0.2, 0.9, 0.5, 0.3, 1.0])
    width = np.array([0.01, 0.02, 0.03, 0.04, 0.05])
    labels = voxelise(poses, score, width, k_max=4)
    assert labels.voxel_index.tolist() == [[3, 17, 9], [4, 17, 9]]
    assert np.allclose(labels.score, [0.9, 0.3]) and np.allclose(labels.width, [0.02, 0.04])
    assert labels.mask.sum(axis=1).tolist() == [2, 1]
    # best first: the flipped twin (score 0.9), then the 30° one
    assert rotation_angle_up_to_flip(labels.rotations[0, 0], R) < 1e-3  # float32
    assert np.degrees(rotation_angle_up_to_flip(labels.rotations[0, 1], R)) == pytest.approx(
        30, abs=1e-3
    )
    assert voxelise(poses, score, width, k_max=1).dropped == 1
