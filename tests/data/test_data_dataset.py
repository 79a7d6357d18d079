"""Augmentation against an independent construction, the batch layout, bad files."""

import json
import warnings

import numpy as np
import pytest
import torch
from scipy.spatial.transform import Rotation

from symgrasp.data.dataset import (
    ITEM_KEYS,
    GraspDataset,
    collate_scenes,
    in_split,
    load_scene,
    make_item,
    rotate_quarter_turns,
    shift_vertical,
)
from symgrasp.data.labels import voxelise
from symgrasp.workspace import RESOLUTION, VOXEL_SIZE

CENTRE = np.array([0.15, 0.15, 0.0])


def _field(p: np.ndarray) -> np.ndarray:
    """A TSDF-like field without any symmetry, evaluated at points (..., 3)."""
    x, y, z = p[..., 0], p[..., 1], p[..., 2]
    return np.tanh(np.sin(31 * x) + np.cos(17 * y) * z * 9 + 40 * x * y - 3 * z)


def _centres() -> np.ndarray:
    i = np.arange(RESOLUTION)
    return (np.stack(np.meshgrid(i, i, i, indexing="ij"), axis=-1) + 0.5) * VOXEL_SIZE


def _grasps(seed: int = 0, n: int = 300):
    rng = np.random.default_rng(seed)
    T = np.tile(np.eye(4), (n, 1, 1))
    T[:, :3, :3] = Rotation.random(n, random_state=seed).as_matrix()
    # clustered so that voxels hold several grasps
    T[:, :3, 3] = rng.uniform(0.02, 0.28, (n // 10, 3)).repeat(10, axis=0) + rng.normal(
        0, 0.004, (n, 3)
    )
    return T, rng.random(n), rng.uniform(0.01, 0.08, n)


def _item(T, score, width, tsdf):
    labels = voxelise(T, score, width, k_max=4)
    return make_item(
        tsdf, labels.voxel_index, labels.score, labels.rotations, labels.mask, labels.width
    )


def _sorted(item):
    order = np.lexsort(item["voxel_index"].numpy().T[::-1])
    return {
        k: (v[order] if k in ("voxel_index", "rotations", "rotation_mask", "width") else v)
        for k, v in item.items()
    }


def _assert_items_equal(a, b):
    a, b = _sorted(a), _sorted(b)
    for key in a:
        assert a[key].shape == b[key].shape, key
        assert torch.allclose(a[key].float(), b[key].float(), atol=1e-5), key


@pytest.mark.parametrize("turns", [1, 2, 3])
def test_quarter_turn_matches_labelling_the_turned_scene(turns):
    """Oracle: turn the grasps and the field in the world about the workspace's vertical
    axis, then voxelise and sample them from scratch."""
    T, score, width = _grasps()
    item = _item(T, score, width, _field(_centres()))
    Rz = np.eye(4)
    Rz[:3, :3] = Rotation.from_euler("z", turns * np.pi / 2).as_matrix()
    move = np.eye(4)
    move[:3, 3] = CENTRE
    W = move @ Rz @ np.linalg.inv(move)  # about the vertical line through the centre
    turned_field = _field((_centres() - CENTRE) @ Rz[:3, :3] + CENTRE)  # f(W⁻¹ p)
    expected = _item(W @ T, score, width, turned_field)
    assert item["valid"].sum() > 50
    _assert_items_equal(rotate_quarter_turns(item, turns), expected)


@pytest.mark.parametrize("dz", [-2, 1, 2])
def test_vertical_shift_matches_labelling_the_shifted_scene(dz):
    T, score, width = _grasps(seed=1)
    item = _item(T, score, width, _field(_centres()))
    moved = T.copy()
    moved[:, 2, 3] += dz * VOXEL_SIZE
    expected = _item(moved, score, width, _field(_centres() - [0, 0, dz * VOXEL_SIZE]))
    shifted = shift_vertical(item, dz)
    inner = slice(max(dz, 0), RESOLUTION + min(dz, 0))  # layers that were not exposed
    assert torch.allclose(shifted["tsdf"][..., inner], expected["tsdf"][..., inner], atol=1e-6)
    for key in ("valid", "score"):
        assert torch.equal(shifted[key], expected[key])
    del shifted["tsdf"], expected["tsdf"]
    _assert_items_equal(shifted, expected)


def test_collate_adds_the_batch_index():
    items = [_item(*_grasps(seed=s, n=50), _field(_centres())) for s in (0, 1)]
    batch = collate_scenes(items)
    m0, m1 = len(items[0]["voxel_index"]), len(items[1]["voxel_index"])
    assert batch["tsdf"].shape == (2, 1, 40, 40, 40) and batch["valid"].shape == (2, 40, 40, 40)
    assert batch["voxel_index"].shape == (m0 + m1, 4) and batch["voxel_index"].dtype == torch.int64
    assert batch["voxel_index"][:, 0].tolist() == [0] * m0 + [1] * m1
    b, i, j, k = batch["voxel_index"].T
    assert torch.all(batch["valid"][b, i, j, k] == 1)
    assert batch["rotations"].shape == (m0 + m1, 4, 3, 3)
    assert batch["rotation_mask"].shape == (m0 + m1, 4) and batch["width"].shape == (m0 + m1,)


def test_split_is_every_tenth_scene():
    val = [i for i in range(30) if in_split(i, "val")]
    assert val == [9, 19, 29]
    assert all(in_split(i, "train") != in_split(i, "val") and in_split(i, "all") for i in range(30))


def test_dataset_rejects_a_folder_without_manifest_and_bad_splits(tmp_path):
    with pytest.raises(ValueError, match="manifest"):
        GraspDataset(tmp_path)
    with pytest.raises(ValueError, match="split"):
        GraspDataset(tmp_path, split="test")


def test_missing_and_corrupted_files_are_reported_by_path_and_skipped(tmp_path):
    manifest = {"gripper": "franka", "object_set": "blocks", "k_max": 4, "scene_ids": [0, 1, 2]}
    (tmp_path / "manifest.json").write_text(json.dumps(manifest))
    scenes = tmp_path / "scenes"
    scenes.mkdir()
    T, score, width = _grasps(n=20)
    labels = voxelise(T, score, width, k_max=4)
    np.savez_compressed(
        scenes / "scene_000000.npz",
        tsdf=_field(_centres()).astype(np.float16),
        voxel_index=labels.voxel_index,
        voxel_score=labels.score,
        voxel_width=labels.width,
        voxel_rotations=labels.rotations,
        voxel_rotation_mask=labels.mask,
    )
    (scenes / "scene_000001.npz").write_bytes(b"not a zip file")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        data = GraspDataset(tmp_path, split="all")
    messages = " ".join(str(w.message) for w in caught)
    assert "scene_000001.npz" in messages and "scene_000002.npz" in messages
    assert len(data) == 1
    item = data[0]
    assert item["tsdf"].dtype == torch.float32 and item["tsdf"].shape == (1, 40, 40, 40)
    assert item["valid"].sum() == len(item["voxel_index"]) > 0


def test_load_scene_reads_only_the_asked_arrays_and_names_a_missing_one(tmp_path):
    path = tmp_path / "scene.npz"
    arrays = {key: np.arange(3) for key in ITEM_KEYS}
    np.savez_compressed(path, depth=np.ones((48, 64), np.uint16), **arrays)
    assert set(load_scene(path)) == {*ITEM_KEYS, "depth"}
    assert set(load_scene(path, ITEM_KEYS)) == set(ITEM_KEYS)
    np.savez_compressed(path, **{k: v for k, v in arrays.items() if k != "voxel_rotation_mask"})
    with pytest.raises(ValueError, match=r"scene.npz is corrupted: no \['voxel_rotation_mask'\]"):
        load_scene(path, ITEM_KEYS)
