"""Spread labels (`SceneConfig.label_spread`): the voxels a grasp's tolerance reaches, against
brute force and a box whose graspable voxels are known in closed form; the default is today's
labels to the byte."""

import dataclasses

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from symgrasp.config import DatabaseConfig, SceneConfig
from symgrasp.data.generate import config_from_dict
from symgrasp.data.grasp_db import OnDemandDatabase, build_database
from symgrasp.data.labels import (
    added_voxels,
    spread_poses,
    voxel_centre,
    voxel_grasp,
    voxel_of,
    voxelise,
)
from symgrasp.data.scenes import labelled_scene, make_scene_record, scene_pool, spread_labels
from symgrasp.sim import FRANKA
from symgrasp.sim.collision import hand_collides
from symgrasp.sim.execute import top_grasp
from symgrasp.workspace import RESOLUTION, TABLE_HEIGHT, VOXEL_SIZE

V = VOXEL_SIZE


def _spread(back, forward, y, z) -> SceneConfig:
    """A configuration spreading by these many voxels."""
    return SceneConfig(label_spread=(back * V, forward * V, y * V, z * V))


def _box_points(lo, hi, spacing=0.002) -> np.ndarray:
    """Points on the six faces of the axis-aligned box [lo, hi] [m], a grid of ``spacing``."""
    lo, hi = np.asarray(lo), np.asarray(hi)
    axes = [
        np.linspace(lo[a], hi[a], int(np.ceil((hi[a] - lo[a]) / spacing)) + 1) for a in range(3)
    ]
    faces = []
    for a in range(3):
        b, c = [x for x in range(3) if x != a]
        u, w = np.meshgrid(axes[b], axes[c], indexing="ij")
        for side in (lo[a], hi[a]):
            face = np.zeros((u.size, 3))
            face[:, a], face[:, b], face[:, c] = side, u.ravel(), w.ravel()
            faces.append(face)
    return np.concatenate(faces)


def test_spread_poses_reach_the_voxel_centres_of_the_box_in_the_grasp_frame():
    rng = np.random.default_rng(0)
    R = Rotation.random(5, random_state=1).as_matrix()
    T = np.tile(np.eye(4), (5, 1, 1))
    T[:, :3, :3] = R
    T[:, :3, 3] = rng.uniform(0.02, 0.28, (5, 3))
    lower, upper = np.array([-0.008, -0.005, -0.012]), np.array([0.017, 0.005, 0.012])
    poses, source = spread_poses(T, lower, upper)
    # oracle: every voxel of the grid, its centre's offset in each grasp's frame
    grid = np.stack(np.meshgrid(*[np.arange(RESOLUTION)] * 3, indexing="ij"), -1).reshape(-1, 3)
    for g in range(5):
        d = (voxel_centre(grid) - T[g, :3, 3]) @ R[g]
        inside = np.all((d >= lower) & (d <= upper), axis=1)
        own = np.all(grid == voxel_of(T[g, :3, 3][None]), axis=1)
        expected = {tuple(v) for v in grid[inside & ~own].tolist()}
        mine = poses[source == g]
        assert {tuple(v) for v in voxel_of(mine[:, :3, 3]).tolist()} == expected
        assert len(mine) == len(expected) > 10
        assert np.allclose(voxel_centre(voxel_of(mine[:, :3, 3])), mine[:, :3, 3])
        assert np.allclose(mine[:, :3, :3], R[g])  # the grasp's rotation
    assert np.all(np.diff(source) >= 0)  # in the order of the grasps


def test_spread_poses_axis_aligned_closed_form_and_the_grid_edge():
    T = top_grasp(voxel_centre([10, 20, 0]))  # e_x = −z, e_y = +y, e_z = +x; the grid's floor
    poses, _ = spread_poses(
        T[None], np.array([-1.2 * V, -1.2 * V, 0]), np.array([2.2 * V, 1.2 * V, 0])
    )
    # back (+z) one voxel, forward (−z) two, ±1 along y; below the grid's floor is left out
    expected = {(10, 20 + b, 1) for b in (-1, 0, 1)} | {(10, 19, 0), (10, 21, 0)}
    assert {tuple(v) for v in voxel_of(poses[:, :3, 3]).tolist()} == expected
    with pytest.raises(ValueError, match="lower ≤ 0 ≤ upper"):
        spread_poses(T[None], np.array([0.01, 0, 0]), np.zeros(3))


def test_a_box_on_the_table_is_labelled_where_the_open_hand_clears_it():
    """Closed form: a top grasp of the Franka hand centred over a 40.5 mm wide, long box. Its
    pads' inner faces stand max_width / 2 = 40 mm from the TCP; with the 1 mm clearance the
    check asks for, a move along the closing axis (world x) by d is free while
    |d| ≤ 40 − 1 − 20.25 = 18.75 mm: ±1 and ±2 voxels, not ±3. The palm's face stands 37 mm
    behind the TCP and the box's top 20 mm above it: a move down (forward along e_x) is free
    while it is ≤ 37 − 1 − 20 = 16 mm: 1 and 2 voxels, not 3. Up and along the box (world y)
    nothing is in the way."""
    i, j, k = 20, 20, 12
    tcp = voxel_centre([i, j, k])
    top = tcp[2] + 0.02
    points = _box_points(
        [tcp[0] - 0.02025, tcp[1] - 0.1, TABLE_HEIGHT], [tcp[0] + 0.02025, tcp[1] + 0.1, top]
    )
    cfg = _spread(1.3, 3.3, 1.3, 3.3)
    T = top_grasp(tcp)[None]
    labels = spread_labels(
        T, np.array([0.7]), np.array([0.04]), cfg,
        lambda poses: hand_collides(poses, FRANKA, points, tolerance=-cfg.clearance),
    )  # fmt: skip
    expected = {
        (i + a, j + b, k + c) for a in range(-2, 3) for b in (-1, 0, 1) for c in (1, 0, -1, -2)
    }
    assert {tuple(v) for v in labels.voxel_index.tolist()} == expected
    assert np.allclose(labels.score, 0.7) and np.allclose(labels.width, 0.04)
    assert np.allclose(labels.rotations[:, 0], T[0, :3, :3]) and labels.mask.sum(1).max() == 1
    # the grasp itself is free, so the box is the only thing the spread is cut by
    assert not hand_collides(T, FRANKA, points, tolerance=-cfg.clearance)[0]


def test_spread_labels_merge_per_voxel_like_voxelise():
    """Two grasps whose tolerance boxes overlap: each shared voxel keeps the better score and
    both rotations, best first; what a half-space check refuses is not labelled."""
    a = top_grasp(voxel_centre([10, 10, 10]))
    b = top_grasp(voxel_centre([10, 11, 10]), yaw=np.pi / 2)
    T = np.stack([a, b])
    cfg = _spread(0, 0, 1.2, 1.2)  # the square of 3 × 3 voxels about each TCP, in its plane
    labels = spread_labels(T, np.array([0.3, 0.8]), np.array([0.01, 0.02]), cfg,
                           lambda p: np.zeros(len(p), dtype=bool))  # fmt: skip
    cells = {tuple(v): n for n, v in enumerate(labels.voxel_index.tolist())}
    square = lambda jc: {(10 + x, jc + y, 10) for x in (-1, 0, 1) for y in (-1, 0, 1)}  # noqa: E731
    assert set(cells) == square(10) | square(11)
    for v, n in cells.items():
        both = v in square(10) and v in square(11)
        assert labels.score[n] == pytest.approx(0.8 if v in square(11) else 0.3)
        assert labels.width[n] == pytest.approx(0.02 if v in square(11) else 0.01)
        assert labels.mask[n].sum() == (2 if both else 1)
        assert np.allclose(labels.rotations[n, 0], (b if v in square(11) else a)[:3, :3])
    cut = spread_labels(T, np.array([0.3, 0.8]), np.array([0.01, 0.02]), cfg,
                        lambda p: p[:, 0, 3] > voxel_centre([10, 0, 0])[0])  # fmt: skip
    # the moves to x = 11 are refused; the TCPs' own voxels stay, as today
    assert {tuple(v) for v in cut.voxel_index.tolist()} == {
        v for v in square(10) | square(11) if v[0] <= 10
    }


def test_added_voxels_are_the_spreads_own_and_none_without_a_spread():
    rng = np.random.default_rng(3)
    T = np.tile(np.eye(4), (30, 1, 1))
    T[:, :3, :3] = Rotation.random(30, random_state=4).as_matrix()
    T[:, :3, 3] = rng.uniform(0.05, 0.25, (30, 3))
    score, width = np.ones(30), np.full(30, 0.04)
    assert not added_voxels(voxelise(T, score, width).voxel_index, T).any()
    moved, source = spread_poses(T, np.array([-V, -V, -V]), np.array([2 * V, V, V]))
    spread = voxelise(
        np.concatenate([T, moved]), np.ones(30 + len(source)), np.ones(30 + len(source))
    )
    added = added_voxels(spread.voxel_index, T)
    # oracle: an added voxel's box holds no grasp's TCP; every other voxel's box holds one
    centres = voxel_centre(spread.voxel_index)
    inside = np.all(np.abs(centres[:, None] - T[None, :, :3, 3]) <= V / 2, axis=-1).any(axis=1)
    assert np.array_equal(added, ~inside) and added.sum() > 30


def test_voxel_grasp_is_at_the_centre_with_one_of_the_voxels_targets():
    rotations = np.tile(np.eye(3), (4, 1, 1))
    rotations[1:3] = Rotation.random(2, random_state=5).as_matrix()
    mask = np.array([False, True, True, False])
    rng = np.random.default_rng(0)
    drawn = [voxel_grasp(np.array([3, 0, 39]), rotations, mask, rng) for _ in range(40)]
    assert all(np.allclose(T[:3, 3], [3.5 * V, 0.5 * V, 39.5 * V]) for T in drawn)
    picked = [int(np.argmin([np.abs(T[:3, :3] - R).max() for R in rotations])) for T in drawn]
    assert all(np.allclose(T[:3, :3], rotations[k]) for T, k in zip(drawn, picked, strict=True))
    assert set(picked) == {1, 2}  # both targets, never a padded one


@pytest.fixture(scope="module")
def tiny():
    """A pool of two blocks with small Franka databases."""
    cfg = SceneConfig(object_set="blocks", gripper="franka", pool_size=2,
                      database=DatabaseConfig(grasps=40, directions=8))  # fmt: skip
    pool = scene_pool(cfg)
    databases = [
        build_database(o, FRANKA, cfg.database, seed=k) for k, o in enumerate(pool.objects)
    ]
    return cfg, pool, databases


def test_the_default_labels_are_todays_to_the_byte(tiny):
    cfg, pool, databases = tiny
    record = make_scene_record(0, cfg, FRANKA, pool, databases)
    scene, _ = labelled_scene(0, cfg, FRANKA, pool, databases)
    ok = scene.survivors
    assert ok.sum() > 0
    today = voxelise(scene.grasps["T_world_tcp"][ok], scene.grasps["score"][ok],
                     scene.grasps["width"][ok], cfg.k_max)  # fmt: skip
    for field in dataclasses.fields(today):
        assert np.array_equal(getattr(scene.labels, field.name), getattr(today, field.name))
    assert np.array_equal(record["voxel_index"], today.voxel_index.astype(np.int16))
    assert record["voxel_rotations"].tobytes() == today.rotations.tobytes()
    assert record["voxel_score"].tobytes() == today.score.tobytes()


def test_a_scene_labelled_from_databases_scored_on_demand_is_the_same_scene(tiny):
    """The same labels, survivor by survivor, from databases that measure only what the scene
    reads: the collision check first, then the survivors' scores along gravity."""
    cfg, pool, databases = tiny
    whole, _ = labelled_scene(0, cfg, FRANKA, pool, databases)
    lazy_dbs = [
        OnDemandDatabase(o, FRANKA, cfg.database, seed=k) for k, o in enumerate(pool.objects)
    ]
    lazy, _ = labelled_scene(0, cfg, FRANKA, pool, lazy_dbs)
    ok = whole.survivors
    assert np.array_equal(lazy.survivors, ok) and ok.any()
    assert np.array_equal(lazy.grasps["score"][ok], whole.grasps["score"][ok])
    assert np.isnan(lazy.grasps["score"][~ok]).all()  # read nowhere, so never measured
    for field in dataclasses.fields(whole.labels):
        assert np.array_equal(getattr(lazy.labels, field.name), getattr(whole.labels, field.name))


def test_spread_scene_labels_pass_the_collision_check_and_keep_todays(tiny):
    cfg, pool, databases = tiny
    spread = dataclasses.replace(cfg, label_spread=(V, 2 * V, V, V))
    today, _ = labelled_scene(0, cfg, FRANKA, pool, databases)
    scene, _ = labelled_scene(0, spread, FRANKA, pool, databases)
    labels = scene.labels
    old = {tuple(v): n for n, v in enumerate(today.labels.voxel_index.tolist())}
    new = {tuple(v): n for n, v in enumerate(labels.voxel_index.tolist())}
    assert set(old) <= set(new) and len(new) >= 2 * len(old)
    for v, n in old.items():  # today's voxels keep their best score (or gain a better one)
        assert labels.score[new[v]] >= today.labels.score[n]
    added = [n for v, n in new.items() if v not in old]
    poses = np.tile(np.eye(4), (len(added), 1, 1))
    poses[:, :3, :3] = labels.rotations[added, 0]
    poses[:, :3, 3] = voxel_centre(labels.voxel_index[added])
    assert not hand_collides(poses, FRANKA, scene.grasps["points"], -cfg.clearance).any()
    # each added rotation target is a surviving grasp's rotation
    R = scene.grasps["T_world_tcp"][scene.survivors][:, :3, :3]
    targets = labels.rotations[added][labels.mask[added]]
    assert np.abs(targets[:, None] - R[None]).max(axis=(2, 3)).min(axis=1).max() < 1e-5
    # the scene is the same scene: objects, grasps, the check's samples
    assert np.array_equal(scene.poses, today.poses)
    assert np.array_equal(scene.grasps["points"], today.grasps["points"])


@pytest.mark.parametrize(
    "spread, message",
    [((0.0, 0.0, 0.0), "label_spread must be four distances"),
     ((0.0, -0.001, 0.0, 0.0), r"label_spread \(forward\) must be a number in \[0, 0.05\]"),
     ((0.0, 0.0, 0.0, 0.2), r"label_spread \(e_z\) must be")],
)  # fmt: skip
def test_a_bad_spread_is_refused_by_name(spread, message):
    with pytest.raises(ValueError, match=message):
        SceneConfig(label_spread=spread)


def test_a_manifest_from_before_the_spread_reads_as_no_spread():
    recorded = dataclasses.asdict(SceneConfig(label_spread=(0.0, 0.01, 0.0, 0.0)))
    assert config_from_dict(recorded).label_spread == (0.0, 0.01, 0.0, 0.0)
    del recorded["label_spread"]
    assert config_from_dict(recorded) == SceneConfig()
