"""VGN's network run by symgrasp: its input convention against a TSDF known in closed form,
its grasp frame against hand-made grasps, its decoding, and (with VGN's weights) the network's
outputs on rendered scenes."""

import numpy as np
import pytest
import torch

from symgrasp.detect.planner import GraspPlanner, Observation
from symgrasp.objects.folder import DATA_ENV, MissingData
from symgrasp.peers.vgn import (
    BAND,
    FINGER_REACH,
    TRUNCATION_VOXELS,
    VGN,
    decode,
    fuse,
    load_network,
    to_symgrasp,
    vgn_grid,
)
from symgrasp.perception import CameraIntrinsic, default_extrinsic, look_at
from symgrasp.sim import get_gripper
from symgrasp.workspace import RESOLUTION, TABLE_HEIGHT, VOXEL_SIZE

EYE = np.array([0.15, 0.15, 0.75])
"""A camera straight above the workspace centre (looking down, image up along world +x)."""
BOX_LO, BOX_HI = np.array([0.11, 0.12]), np.array([0.19, 0.18])
"""The box's footprint on the table [m]."""
BOX_TOP = TABLE_HEIGHT + 0.06
"""The box's top [m]."""
TRUNCATION = TRUNCATION_VOXELS * VOXEL_SIZE


def _surface_below(points: np.ndarray) -> np.ndarray:
    """The height [m] of the surface the camera's ray through each of ``points`` (N, 3) ends
    on: the box's top where the ray crosses its plane inside the footprint, else the table (the
    camera is above the box's centre, so it sees none of its sides)."""
    scale = (EYE[2] - BOX_TOP) / (EYE[2] - points[:, 2])
    crossing = EYE[:2] + (points[:, :2] - EYE[:2]) * scale[:, None]
    on_box = np.all((crossing >= BOX_LO) & (crossing <= BOX_HI), axis=1)
    return np.where(on_box, BOX_TOP, TABLE_HEIGHT)


def _box_scene() -> tuple[np.ndarray, CameraIntrinsic, np.ndarray]:
    """The depth image of the box on the table from `EYE`, in closed form."""
    intrinsic = CameraIntrinsic()
    T = look_at(EYE, (0.15, 0.15, 0.0), up=(1.0, 0.0, 0.0))
    rays = intrinsic.pixel_rays() @ T[:3, :3].T  # world directions, camera z = 1
    far = EYE + rays * (EYE[2] - TABLE_HEIGHT)  # where each ray meets the table
    surface = _surface_below(far.reshape(-1, 3)).reshape(far.shape[:2])
    return (EYE[2] - surface).astype(np.float32), intrinsic, T


def _expected_grid() -> tuple[np.ndarray, np.ndarray]:
    """VGN's input for `_box_scene` in closed form, and which voxels it is certain for (their
    ray and the rays one pixel beside it end on the same surface)."""
    idx = (np.arange(RESOLUTION) + 0.5) * VOXEL_SIZE
    centres = np.stack(np.meshgrid(idx, idx, idx, indexing="ij"), -1).reshape(-1, 3)
    depth_of_voxel = EYE[2] - centres[:, 2]  # the camera looks straight down
    surface = _surface_below(centres)
    sure = np.ones(len(centres), dtype=bool)
    for axis in (0, 1):  # a pixel is 1/540 of the depth wide: shift the ray sideways by that
        for sign in (-1.5, 1.5):
            moved = centres.copy()
            moved[:, axis] += sign * depth_of_voxel / 540.0
            sure &= _surface_below(moved) == surface
    along_ray = np.linalg.norm(centres - EYE, axis=1) / depth_of_voxel
    signed = (centres[:, 2] - surface) * along_ray / TRUNCATION
    tsdf = np.minimum(signed, 1.0)
    expected = np.where((signed > -1) & (tsdf >= -BAND) & (tsdf < BAND), (tsdf + 1) / 2, 0.0)
    sure &= np.abs(np.abs(tsdf) - BAND) > 1e-3  # not on the band's edge, where float32 decides
    shape = (RESOLUTION,) * 3
    return expected.reshape(shape), sure.reshape(shape)


def test_vgns_input_of_a_box_on_the_table_is_its_closed_form():
    """VGN's grid (Open3D's TSDF read by ``get_grid``): (tsdf + 1) / 2 inside the truncation
    band, the distance along the ray, 0 for free space beyond the band and for what lies hidden
    behind it; a surface reads 0.5."""
    depth, intrinsic, T = _box_scene()
    grid = vgn_grid(fuse(depth, intrinsic, T)).numpy()
    expected, sure = _expected_grid()
    assert sure.mean() > 0.9
    np.testing.assert_allclose(grid[sure], expected[sure], atol=1e-3)
    column = grid[20, 20]  # through the box's top, at the workspace's centre
    k_top = int(BOX_TOP / VOXEL_SIZE)  # the voxel just below the top (its centre at 0.1088 m)
    assert 0.45 < column[k_top] < 0.5 < column[k_top + 1] < 0.7
    assert (column[k_top + 5 :] == 0).all()  # free beyond the band: empty
    assert (column[: k_top - 4] == 0).all()  # hidden inside the box: empty too
    assert 0 < grid[grid > 0].min() and grid.max() < 1


def test_vgns_fusion_drops_depth_beyond_two_metres():
    depth, intrinsic, T = _box_scene()
    assert vgn_grid(fuse(depth + 1.5, intrinsic, T)).count_nonzero() == 0  # all beyond 2 m


def test_a_top_down_vgn_grasp_maps_to_symgrasps_frame_with_the_fingertips_in_place():
    """Hand-made: VGN's grasp approaching straight down (its z = −world z) and closing along
    world x (its y), quaternion (1, 1, 0, 0)/√2 (x, y, z, w): 180° about (1, 1, 0)/√2."""
    q = np.array([[1.0, 1.0, 0.0, 0.0]]) / np.sqrt(2)
    position = np.array([[0.15, 0.12, 0.10]])
    for name in ("franka", "robotiq-2f85"):
        gripper = get_gripper(name)
        pose = to_symgrasp(position, q, gripper)[0]
        np.testing.assert_allclose(pose[:3, 0], [0, 0, -1], atol=1e-12)  # e_x: approach
        np.testing.assert_allclose(np.abs(pose[:3, 2]), [1, 0, 0], atol=1e-12)  # e_z: closing
        np.testing.assert_allclose(pose[:3, :3] @ pose[:3, :3].T, np.eye(3), atol=1e-12)
        assert np.linalg.det(pose[:3, :3]) == pytest.approx(1.0)
        fingertips = pose[:3, 3] + gripper.tip_beyond_tcp * pose[:3, 0]
        vgn_fingertips = position[0] + FINGER_REACH * np.array([0, 0, -1])
        np.testing.assert_allclose(fingertips, vgn_fingertips, atol=1e-12)
    assert FINGER_REACH == pytest.approx(0.0503)  # VGN's 50 mm finger depth


def test_the_mapping_is_the_axis_permutation_for_any_rotation():
    """e_x, e_y, e_z = VGN's z, x, y for random quaternions, unnormalised ones included."""
    rng = np.random.default_rng(0)
    q = rng.normal(size=(50, 4)) * rng.uniform(0.5, 2, size=(50, 1))
    poses = to_symgrasp(np.zeros((50, 3)), q, get_gripper("franka"))
    from scipy.spatial.transform import Rotation

    R_vgn = Rotation.from_quat(q).as_matrix()  # scipy: (x, y, z, w), normalised
    np.testing.assert_allclose(poses[:, :3, 0], R_vgn[:, :, 2], atol=1e-9)
    np.testing.assert_allclose(poses[:, :3, 1], R_vgn[:, :, 0], atol=1e-9)
    np.testing.assert_allclose(poses[:, :3, 2], R_vgn[:, :, 1], atol=1e-9)


def _decode_inputs() -> tuple[np.ndarray, ...]:
    """A flat surface between z-indices 9 and 10 (inside below, free above) and two blobs of
    high quality on its free side."""
    grid = np.zeros((40,) * 3, np.float32)
    grid[:, :, 6:10] = 0.3  # inside the band, below the surface
    grid[:, :, 10:14] = 0.7  # the free side of the band
    quality = np.full((40,) * 3, 0.2, np.float32)
    quality[8:13, 8:13, 10:15] = 1.0  # two blobs whose smoothed peaks are (10, 10, 12) ...
    quality[28:33, 18:23, 10:15] = 0.95  # ... and (30, 20, 12)
    rotation = np.zeros((40,) * 3 + (4,), np.float32)
    rotation[..., 3] = 1.0
    width = np.full((40,) * 3, 5.0, np.float32)
    return grid, quality, rotation, width


def test_decoding_keeps_smoothed_peaks_on_the_free_side_best_first():
    grid, quality, rotation, width = _decode_inputs()
    found = decode(grid, quality.copy(), rotation, width)
    assert [tuple(i) for i in found.index] == [(10, 10, 12), (30, 20, 12)]
    assert 0.9 < found.quality[1] < found.quality[0] < 1
    np.testing.assert_array_equal(found.quaternion, [[0, 0, 0, 1]] * 2)
    narrow = width.copy()
    narrow[30, 20, 12] = 1.0  # 7.5 mm: narrower than VGN's 10 mm
    kept = [tuple(i) for i in decode(grid, quality.copy(), rotation, narrow).index]
    assert kept[0] == (10, 10, 12) and (30, 20, 12) not in kept
    inside = quality.copy()
    inside[:, :, 10:15], inside[8:13, 8:13, 4:9] = 0.2, 1.0  # a blob inside the object
    assert len(decode(grid, inside, rotation, width).index) == 0


def test_decoding_forces_one_grasp_only_when_none_reaches_the_threshold():
    grid, quality, rotation, width = _decode_inputs()
    forced = decode(grid, quality.copy(), rotation, width, threshold=0.99, force=True)
    assert [tuple(i) for i in forced.index] == [(10, 10, 12)]  # the best alone
    assert len(decode(grid, quality.copy(), rotation, width, 0.99, force=False).index) == 0
    low = np.full_like(quality, 0.4)
    assert len(decode(grid, low, rotation, width, force=True).index) == 0  # below 0.5: none


def test_missing_weights_are_named_with_how_to_get_them(tmp_path, monkeypatch):
    monkeypatch.setenv(DATA_ENV, str(tmp_path))
    with pytest.raises(MissingData, match=r"peers/vgn/vgn_conv.pth does not exist.*b47ab53"):
        VGN()
    bogus = tmp_path / "bogus.pth"
    torch.save({"layer.weight": torch.zeros(2)}, bogus)
    with pytest.raises(ValueError, match="not VGN's ConvNet"):
        load_network(bogus)


def test_the_network_loads_and_meets_the_planner_interface(vgn_weights, monkeypatch):
    monkeypatch.setenv(DATA_ENV, str(vgn_weights))
    vgn = VGN()
    assert isinstance(vgn, GraspPlanner)
    assert vgn.gripper.name == "franka" and len(vgn.version) == 64
    out = vgn.predict(torch.zeros((40,) * 3))
    assert out["quality"].shape == (40, 40, 40) and out["rotation"].shape == (40, 40, 40, 4)
    torch.testing.assert_close(out["rotation"].norm(dim=-1), torch.ones(40, 40, 40))


def test_the_network_sees_grasps_on_objects_and_none_on_the_empty_table(vgn_weights, monkeypatch):
    """On a rendered pile the quality next to the objects' surfaces peaks above VGN's 0.9 and
    the best grasp's fingertips reach an observed surface; on the empty table the quality of
    every voxel near the surface stays below 0.5 and VGN proposes nothing."""
    monkeypatch.setenv(DATA_ENV, str(vgn_weights))
    from scipy import ndimage

    from symgrasp.objects.sets import make_scene
    from symgrasp.sim.render import make_renderer
    from symgrasp.sim.world import pile_scene

    vgn = VGN()
    intrinsic, T = CameraIntrinsic(), default_extrinsic()
    render = make_renderer(intrinsic).render
    heights = (np.arange(40) * VOXEL_SIZE)[None, None, :]
    for world, objects in ((make_scene("pile", "household-train", 5, 0, vgn.gripper), True),
                           (pile_scene([], seed=0, gripper=vgn.gripper), False)):  # fmt: skip
        depth = render(world, T)
        grid = vgn_grid(vgn.fuse(depth, intrinsic, T))
        quality = vgn.predict(grid)["quality"].numpy()
        grid = grid.numpy()
        near = ndimage.binary_dilation(
            grid > 0.5, iterations=2, mask=~((grid > 1e-3) & (grid < 0.5))
        )
        near &= grid > 0
        grasps = vgn.plan(Observation(depth, intrinsic, T))
        if objects:
            assert quality[near & (heights > TABLE_HEIGHT + 0.025)].max() > 0.9
            points = Observation(depth, intrinsic, T).points()
            tips = grasps[0].position + vgn.gripper.tip_beyond_tcp * grasps[0].approach
            assert np.linalg.norm(points - tips, axis=1).min() < 0.03
        else:
            assert quality[near].max() < 0.5
            assert grasps == []


def test_vgns_random_order_permutes_the_best_order_reproducibly(vgn_weights, monkeypatch):
    """VGN's own evaluation executes a random grasp above the threshold: the same grasps,
    permuted by a seed drawn from the observation, so a round replays."""
    monkeypatch.setenv(DATA_ENV, str(vgn_weights))
    from symgrasp.objects.sets import make_scene
    from symgrasp.sim.render import make_renderer

    intrinsic, T = CameraIntrinsic(), default_extrinsic()
    world = make_scene("pile", "household-train", 5, 3, get_gripper("franka"))
    observation = Observation(make_renderer(intrinsic).render(world, T), intrinsic, T)
    best = VGN().plan(observation)
    shuffled = VGN(order="random").plan(observation)
    assert len(best) >= 2
    assert sorted(g.voxel for g in shuffled) == sorted(g.voxel for g in best)
    assert [g.voxel for g in VGN(order="random").plan(observation)] == [g.voxel for g in shuffled]
    assert [g.score for g in best] == sorted((g.score for g in best), reverse=True)
    with pytest.raises(ValueError, match="order must be one of"):
        VGN(order="worst")
