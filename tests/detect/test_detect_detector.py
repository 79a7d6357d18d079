"""GraspDetector: decoding against prescribed network outputs, inputs, checkpoints."""

import numpy as np
import pytest
import torch
from conftest import FixedNet, bingham2d_channels, grasp_rotation

from symgrasp.detect import Grasp, GraspDetector
from symgrasp.detect.pretrained import export_model
from symgrasp.model.checkpoint import save_checkpoint
from symgrasp.model.network import GraspNet, NetworkConfig
from symgrasp.model.ranking import local_maxima
from symgrasp.perception import CameraIntrinsic
from symgrasp.perception.camera import default_extrinsic
from symgrasp.sim import FRANKA, ROBOTIQ_2F85, World
from symgrasp.sim.render import make_renderer

R = 40
VOXEL = 0.3 / R


_rotation, _bingham2d = grasp_rotation, bingham2d_channels


ROT_A = _rotation([0, 0, -1], [1, 0, 0])
ROT_B = _rotation([1, 0, -1], [0, 1, 0])


def _detector(voxels, **options) -> GraspDetector:
    return GraspDetector(FixedNet("bingham2d", voxels), ROBOTIQ_2F85, device="cpu", **options)


def test_grasps_sit_at_voxel_centres_with_the_decoded_rotation_sorted_by_score():
    voxels = {(5, 6, 7): (0.4, 0.9, _bingham2d(ROT_A)), (30, 20, 10): (0.8, 0.7, _bingham2d(ROT_B))}
    grasps = _detector(voxels).detect_tsdf(np.ones((R, R, R)))
    assert [g.voxel for g in grasps] == [(30, 20, 10), (5, 6, 7)]
    assert np.allclose(grasps[1].position, (np.array([5, 6, 7]) + 0.5) * VOXEL)
    for g, Rot in zip(grasps, (ROT_B, ROT_A), strict=True):
        assert np.allclose(g.pose[:3, 0], Rot[:, 0], atol=1e-6)
        assert abs(g.pose[:3, 2] @ Rot[:, 2]) == pytest.approx(1.0, abs=1e-6)  # up to the flip
        assert np.allclose(g.pose[:3, :3] @ g.pose[:3, :3].T, np.eye(3), atol=1e-6)
        assert g.confidence == pytest.approx(30.0, abs=1e-4)
    assert grasps[0].score == pytest.approx(0.8) and grasps[0].validity == pytest.approx(0.7)


def test_thresholds_drop_invalid_and_unconfident_voxels():
    voxels = {
        (1, 1, 1): (0.9, 0.05, _bingham2d(ROT_A)),  # invalid at the default 0.08
        (10, 10, 10): (0.8, 0.9, _bingham2d(ROT_A, gaps=(8.0, 5.0))),  # confidence 13 < 15
        (20, 20, 20): (0.1, 0.9, _bingham2d(ROT_A)),
    }
    assert [g.voxel for g in _detector(voxels).detect_tsdf(np.ones((R,) * 3))] == [(20, 20, 20)]
    loose = _detector(voxels, confidence_threshold=0.0, validity_threshold=0.03)
    assert len(loose.detect_tsdf(np.ones((R,) * 3))) == 3


def test_non_maximum_suppression_keeps_the_best_of_each_neighbourhood():
    channels = _bingham2d(ROT_A)
    voxels = {
        (10, 10, 10): (0.5, 0.9, channels),
        (11, 10, 10): (0.6, 0.9, channels),
        (12, 12, 12): (0.55, 0.9, channels),
        (20, 10, 10): (0.3, 0.9, channels),
    }
    kept = [g.voxel for g in _detector(voxels, nms_radius=2).detect_tsdf(np.ones((R,) * 3))]
    assert kept == [(11, 10, 10), (20, 10, 10)]
    all_ = _detector(voxels, nms_radius=0).detect_tsdf(np.ones((R,) * 3))
    assert len(all_) == 4
    assert len(_detector(voxels, nms_radius=0, top_k=2).detect_tsdf(np.ones((R,) * 3))) == 2


@pytest.mark.parametrize("radius", [1, 2, 3])
@pytest.mark.parametrize("region", [(0, R), (1, 9), (30, R)])
def test_non_maximum_suppression_equals_a_brute_force_search_of_each_box(radius, region):
    """Random scores on random candidate voxels in ``region`` (the whole grid, its borders
    included, or a cluster near a corner, as candidates lie on objects), ties included: a
    candidate stays iff no candidate within ``radius`` voxels (Chebyshev) scores higher;
    voxels that are not candidates score higher still and must not count."""
    rng = np.random.default_rng(radius)
    index = np.unique(rng.integers(*region, size=(400, 3)), axis=0)
    if region == (0, R):
        index[:5] = [[0, 0, 0], [0, 0, 1], [39, 39, 39], [38, 39, 39], [20, 20, 20]]
    index = np.unique(index, axis=0)
    value = rng.choice([0.1, 0.2, 0.3, 0.5], size=len(index))  # coarse: many ties
    score = torch.ones(R, R, R, dtype=torch.float64)
    score[tuple(torch.as_tensor(index).T)] = torch.as_tensor(value)
    near = np.abs(index[:, None] - index[None]).max(-1) <= radius
    expected = [value[m] >= value[near[m]].max() for m in range(len(index))]
    kept = local_maxima(score, torch.as_tensor(index), radius)
    assert kept.tolist() == expected
    assert 0 < sum(expected) < len(index)


def test_bounds_keep_only_grasps_inside_the_box():
    voxels = {(5, 5, 5): (0.5, 0.9, _bingham2d(ROT_A)), (30, 30, 30): (0.6, 0.9, _bingham2d(ROT_A))}
    detector = _detector(voxels, bounds=(np.zeros(3), np.full(3, 0.1)))
    assert [g.voxel for g in detector.detect_tsdf(np.ones((R,) * 3))] == [(5, 5, 5)]


def test_samples_per_voxel_draw_closing_axes_around_the_mode_and_keep_the_approach():
    voxels = {(5, 5, 5): (0.5, 0.9, _bingham2d(ROT_A, gaps=(60.0, 2.0)))}
    grasps = _detector(voxels, samples_per_voxel=200, seed=1).detect_tsdf(np.ones((R,) * 3))
    assert len(grasps) == 200 and all(g.voxel == (5, 5, 5) for g in grasps)
    e_z = np.array([g.closing_axis for g in grasps])
    assert np.allclose([g.approach for g in grasps], ROT_A[:, 0], atol=1e-6)
    # B(A) has gap 2 towards e_y = ROT_A[:, 1] and 60 towards e_x: samples spread in the
    # e_y–e_z plane, far more than towards e_x (which Gram–Schmidt removes anyway)
    assert np.std(np.abs(e_z @ ROT_A[:, 1])) > 0.1
    again = _detector(voxels, samples_per_voxel=200, seed=1).detect_tsdf(np.ones((R,) * 3))
    assert np.array_equal(e_z, np.array([g.closing_axis for g in again]))
    with pytest.raises(ValueError, match="samples_per_voxel"):
        GraspDetector(FixedNet("rotmat6d", {}), FRANKA, samples_per_voxel=3)


def test_confidence_threshold_defaults_to_the_papers_value_only_for_bingham2d():
    assert _detector({}).confidence_threshold == 15.0
    assert GraspDetector(FixedNet("rotmat6d", {}), FRANKA).confidence_threshold is None
    assert (
        GraspDetector(FixedNet("rotmat6d", {}), FRANKA, confidence_threshold=0).confidence_threshold
        == 0
    )
    with pytest.raises(ValueError, match="confidence_threshold"):
        GraspDetector(FixedNet("quaternion", {}), FRANKA, confidence_threshold=10.0)
    for bad in (float("nan"), -1.0, "default"):
        with pytest.raises(ValueError, match="confidence_threshold"):
            _detector({}, confidence_threshold=bad)


def test_approach_trajectory_is_pregrasp_grasp_lift():
    pose = np.eye(4)
    pose[:3, :3], pose[:3, 3] = ROT_B, [0.1, 0.2, 0.1]
    grasp = Grasp(pose, 0.5, 0.9, None, (0, 0, 0))
    pre, at, lift = grasp.approach_trajectory()
    assert np.allclose(at, pose)
    assert np.allclose(pre[:3, 3], pose[:3, 3] - 0.10 * ROT_B[:, 0])
    assert np.allclose(lift[:3, 3], pose[:3, 3] + [0, 0, 0.30])
    assert np.allclose(pre[:3, :3], ROT_B) and np.allclose(lift[:3, :3], ROT_B)
    with pytest.raises(ValueError, match="pregrasp_distance"):
        grasp.approach_trajectory(pregrasp_distance=-1)


@pytest.fixture(scope="module")
def empty_table_depth():
    intrinsic = CameraIntrinsic()
    T = default_extrinsic()
    return make_renderer(intrinsic).render(World([]), T), intrinsic, T


def test_detect_fuses_depth_and_an_empty_table_gives_no_grasps(empty_table_depth):
    depth, intrinsic, T = empty_table_depth
    detector = GraspDetector(GraspNet(NetworkConfig()), FRANKA, device="cpu")
    noisy = depth.copy()
    noisy[:10] = np.nan
    noisy[10:20] = np.inf
    noisy[20:30] = 0.0
    assert detector.detect(noisy, intrinsic, T) == []
    assert set(detector.timing) == {"tsdf", "network", "decode", "width"}
    # the table top (z = 0.05 m) is seen: the TSDF changes sign between z-voxels 6 and 7
    tsdf = detector.fuse(depth, intrinsic.K, T).grid()
    assert tsdf[20, 20, 4] < 0 < tsdf[20, 20, 9]
    views = detector.fuse(np.stack([depth, depth]), intrinsic, np.stack([T, T])).grid()
    assert torch.allclose(views, tsdf)


def test_bad_inputs_raise_with_the_offending_shape(empty_table_depth):
    depth, intrinsic, T = empty_table_depth
    detector = GraspDetector(GraspNet(NetworkConfig()), FRANKA, device="cpu")
    with pytest.raises(ValueError, match=r"\(4, 4\)"):
        detector.detect(depth, intrinsic, T[:3])
    with pytest.raises(ValueError, match="rigid"):
        detector.detect(depth, intrinsic, 2 * T)
    with pytest.raises(ValueError, match="480×640"):
        detector.detect(depth[:100], intrinsic, T)
    with pytest.raises(ValueError, match="depth must be"):
        detector.detect(depth[0], intrinsic, T)
    with pytest.raises(ValueError, match="tsdf must be"):
        detector.detect_tsdf(np.ones((32, 32, 32)))
    with pytest.raises(ValueError, match="validity_threshold"):
        GraspDetector(GraspNet(NetworkConfig()), FRANKA, validity_threshold=2.0)
    with pytest.raises(TypeError, match="get_gripper resolves"):  # a name is resolved at the edge
        GraspDetector(GraspNet(NetworkConfig()), "franka")


def test_from_pretrained_loads_a_checkpoint_and_warns_about_another_gripper(tmp_path):
    net = GraspNet(NetworkConfig())
    state = {
        "representation": "bingham2d",
        "gripper": "robotiq-2f85",
        "network": {"representation": "bingham2d", "widths": [8, 16, 32, 64], "features": 16},
        "model": net.state_dict(),
        "optimizer": {"state": {}},
        "epoch": 3,
    }
    save_checkpoint(tmp_path / "last.pt", state)
    shipped = export_model(tmp_path / "last.pt", tmp_path / "small.pt")
    detector = GraspDetector.from_pretrained(shipped, device="cpu", top_k=5)
    assert detector.gripper.name == "robotiq-2f85" and detector.top_k == 5
    assert "optimizer" not in detector.info and detector.info["epoch"] == 3
    tsdf = torch.rand(R, R, R) * 2 - 1
    with torch.no_grad():
        expected = net(tsdf[None, None]).score[0]
    assert torch.allclose(detector.predict(tsdf)["score"], expected)
    with pytest.warns(UserWarning, match="trained for the 'robotiq-2f85' gripper"):
        GraspDetector.from_pretrained(shipped, device="cpu", gripper=FRANKA)
    with pytest.raises(ValueError, match="shipped"):
        GraspDetector.from_pretrained("no-such-model")


def test_the_approach_check_keeps_the_grasps_the_benchmark_would_execute(empty_table_depth):
    """Two grasps straight down over the empty table, the better one's TCP inside the table:
    unchecked, both in rank order; checked, the one above it alone, the grasp the declutter
    benchmark's own check (`first_free` on the fused surface) executes after rejecting one;
    `detect_tsdf` on the fused grid alone the same one."""
    from symgrasp.benchmark.declutter import first_free

    depth, intrinsic, T = empty_table_depth
    down = _bingham2d(_rotation([0, 0, -1], [1, 0, 0]))
    voxels = {(20, 20, 5): (0.9, 0.9, down), (20, 20, 30): (0.5, 0.9, down)}  # z 4.1, 22.9 cm
    unchecked = _detector(voxels, nms_radius=0).detect(depth, intrinsic, T)
    assert [round(g.position[2], 5) for g in unchecked] == [0.04125, 0.22875]
    checker = _detector(voxels, nms_radius=0, approach_check=True)
    checked = checker.detect(depth, intrinsic, T)
    assert len(checked) == 1 and np.array_equal(checked[0].pose, unchecked[1].pose)
    assert set(checker.timing) == {"tsdf", "network", "decode", "approach", "cut", "width"}
    surface = checker.fuse(depth, intrinsic, T).point_cloud().numpy()
    assert abs(np.median(surface[:, 2]) - 0.05) < 0.002  # the table top is what it checks against
    chosen, rejected = first_free(unchecked, ROBOTIQ_2F85, surface)
    assert rejected == 1 and np.array_equal(chosen.pose, checked[0].pose)
    grid = checker.fuse(depth, intrinsic, T).grid()  # the same check on the fused grid alone
    from_grid = checker.detect_tsdf(grid)
    assert len(from_grid) == 1 and np.array_equal(from_grid[0].pose, checked[0].pose)
    assert set(checker.timing) == {"network", "decode", "approach"}
    with pytest.raises(TypeError, match="approach_check must be True or False"):
        _detector(voxels, approach_check="yes")


def _box_tsdf(lo, hi) -> np.ndarray:
    """The workspace TSDF of one solid box ``lo``–``hi`` [m]: its signed distance over a
    truncation of 4 voxels, clipped to [-1, 1]."""
    centres = (np.stack(np.meshgrid(*[np.arange(R)] * 3, indexing="ij"), -1) + 0.5) * VOXEL
    lo, hi = np.asarray(lo), np.asarray(hi)
    q = np.abs(centres - (lo + hi) / 2) - (hi - lo) / 2
    distance = np.linalg.norm(np.maximum(q, 0), axis=-1) + np.minimum(q.max(-1), 0)
    return np.clip(distance / (4 * VOXEL), -1, 1).astype(np.float32)


# A grasp straight down at 15 cm whose most probable closing axis (world y) puts a finger into a
# block beside it, while the closing axis along x clears it.
BLOCKED = _box_tsdf([0.145, 0.18, 0.06], [0.165, 0.23, 0.16])
DOWN_Y = _rotation([0, 0, -1], [0, 1, 0])


def test_fallbacks_rescue_a_voxel_whose_most_probable_yaw_is_blocked():
    """Its Bingham (gap 1 towards e_y = world x) tolerates other yaws: with fallbacks the first
    free draw is returned, marked as one; without, the voxel gives nothing. The benchmark's own
    check (`first_free`) on the unchecked list executes the same grasp."""
    from symgrasp.benchmark.declutter import first_free
    from symgrasp.perception import surface_points

    voxels = {(20, 20, 20): (0.9, 0.9, _bingham2d(DOWN_Y, gaps=(60.0, 1.0)))}
    assert _detector(voxels, approach_check=True, confidence_threshold=0).detect_tsdf(BLOCKED) == []
    checker = _detector(voxels, approach_check=True, confidence_threshold=0, fallbacks=8)
    (rescued,) = checker.detect_tsdf(BLOCKED)
    assert rescued.fallback >= 1 and rescued.voxel == (20, 20, 20)
    assert np.allclose(rescued.approach, [0, 0, -1], atol=1e-12)
    assert abs(rescued.closing_axis[1]) < 0.9  # turned away from the block
    unchecked = _detector(voxels, confidence_threshold=0, fallbacks=8).detect_tsdf(BLOCKED)
    assert [g.fallback for g in unchecked] == list(range(9))
    points = surface_points(torch.as_tensor(BLOCKED)).numpy()
    chosen, rejected = first_free(unchecked, ROBOTIQ_2F85, points)
    assert chosen.fallback == rescued.fallback and rejected == rescued.fallback
    assert np.array_equal(chosen.pose, rescued.pose)
    assert rescued.record()["fallback"] == rescued.fallback


def test_a_free_voxel_needs_no_fallback_and_the_control_turns_a_point_estimate():
    """A voxel whose own grasp is free returns it (fallback 0) and checks nothing more; a
    rotmat6d voxel's fallbacks are its yaw turned by 45°, 90°, 135°: the 45° turn clears."""
    voxels = {(20, 20, 20): (0.9, 0.9, _bingham2d(_rotation([0, 0, -1], [1, 0, 0])))}
    (free,) = _detector(voxels, approach_check=True, fallbacks=8).detect_tsdf(BLOCKED)
    assert free.fallback == 0
    six = np.r_[DOWN_Y[:, 0], DOWN_Y[:, 2]]
    net = FixedNet("rotmat6d", {(20, 20, 20): (0.9, 0.9, six)})
    checked = GraspDetector(net, ROBOTIQ_2F85, device="cpu", approach_check=True, fallbacks=3)
    (turned,) = checked.detect_tsdf(BLOCKED)
    assert turned.fallback == 1
    assert abs(turned.closing_axis @ DOWN_Y[:, 2]) == pytest.approx(np.cos(np.pi / 4), abs=1e-9)


def test_forced_decoding_ranks_the_voxels_below_the_threshold_after_those_above_it():
    voxels = {
        (5, 5, 5): (0.2, 0.9, _bingham2d(ROT_A)),
        (30, 30, 30): (0.9, 0.05, _bingham2d(ROT_A)),  # best score, validity under 0.08
        (20, 5, 30): (0.5, 0.01, _bingham2d(ROT_A)),  # under the floor
    }
    assert [g.voxel for g in _detector(voxels).detect_tsdf(np.ones((R,) * 3))] == [(5, 5, 5)]
    forced = _detector(voxels, validity_floor=0.02).detect_tsdf(np.ones((R,) * 3))
    assert [g.voxel for g in forced] == [(5, 5, 5), (30, 30, 30)]
    only_forced = {k: v for k, v in voxels.items() if k != (5, 5, 5)}
    forced = _detector(only_forced, validity_floor=0.0).detect_tsdf(np.ones((R,) * 3))
    assert [g.voxel for g in forced] == [(30, 30, 30), (20, 5, 30)]  # by score within the tier
    capped = _detector(voxels, validity_floor=0.02, top_k=1).detect_tsdf(np.ones((R,) * 3))
    assert [g.voxel for g in capped] == [(5, 5, 5)]
    both = _detector(voxels, validity_floor=0.02, fallbacks=2).detect_tsdf(np.ones((R,) * 3))
    assert [(g.voxel, g.fallback) for g in both] == [
        ((5, 5, 5), 0), ((5, 5, 5), 1), ((5, 5, 5), 2),
        ((30, 30, 30), 0), ((30, 30, 30), 1), ((30, 30, 30), 2),
    ]  # fmt: skip


def test_the_checked_detector_draws_fallbacks_only_when_needed_and_draws_the_same_ones():
    """Two tiers, the forced voxel's own grasp blocked: the detector's own check returns the
    grasp the benchmark's check finds in the unchecked list, whose draws are made up front."""
    from symgrasp.benchmark.declutter import first_free
    from symgrasp.perception import surface_points

    free = _bingham2d(_rotation([0, 0, -1], [1, 0, 0]))
    voxels = {(8, 8, 20): (0.9, 0.9, free),
              (20, 20, 20): (0.5, 0.05, _bingham2d(DOWN_Y, gaps=(60.0, 1.0)))}  # fmt: skip
    options = {"validity_floor": 0.02, "fallbacks": 8, "confidence_threshold": 0, "seed": 4}
    unchecked = _detector(voxels, **options).detect_tsdf(BLOCKED)
    checked = _detector(voxels, approach_check=True, **options).detect_tsdf(BLOCKED)
    assert [(g.voxel, g.fallback > 0) for g in checked] == [((8, 8, 20), False),
                                                           ((20, 20, 20), True)]  # fmt: skip
    points = surface_points(torch.as_tensor(BLOCKED)).numpy()
    rest = [g for g in unchecked if g.voxel == (20, 20, 20)]
    chosen, _ = first_free(rest, ROBOTIQ_2F85, points)
    assert np.array_equal(chosen.pose, checked[1].pose) and chosen.fallback == checked[1].fallback


def test_decoding_options_are_checked():
    for options, match in (
        ({"validity_floor": 0.5}, "validity_floor"),  # above the threshold 0.08
        ({"validity_floor": -0.1}, "validity_floor"),
        ({"fallbacks": -1}, "fallbacks"),
        ({"fallbacks": 2, "samples_per_voxel": 2}, "choose one"),
        ({"confidence_threshold": True}, "confidence_threshold"),
    ):
        with pytest.raises(ValueError, match=match):
            _detector({}, **options)


def test_a_shipped_models_operating_point_is_its_default_and_options_override_it(monkeypatch):
    """`from_pretrained` reads a shipped model's card (here a stand-in card); a checkpoint file,
    ``operating_point=False`` and explicit options are not changed by it."""
    from symgrasp.detect import pretrained

    card = {"validity_threshold": 0.05, "confidence_threshold": 0.0, "validity_floor": 0.01,
            "fallbacks": 4}  # fmt: skip
    monkeypatch.setattr(
        pretrained, "_read_operating_points", lambda: {"bingham2d-franka": {**card, "chosen": {}}}
    )
    assert pretrained.shipped_operating_point("bingham2d-franka") == card
    assert pretrained.shipped_operating_point(pretrained.shipped_path("bingham2d-franka")) == {}
    detector = GraspDetector.from_pretrained("bingham2d-franka", device="cpu")
    assert (detector.validity_threshold, detector.confidence_threshold) == (0.05, 0.0)
    assert (detector.validity_floor, detector.fallbacks) == (0.01, 4)
    mine = GraspDetector.from_pretrained("bingham2d-franka", device="cpu", fallbacks=0)
    assert (mine.validity_threshold, mine.fallbacks) == (0.05, 0)
    plain = GraspDetector.from_pretrained("bingham2d-franka", device="cpu", operating_point=False)
    assert (plain.validity_threshold, plain.validity_floor, plain.fallbacks) == (0.08, None, 0)


def test_the_shipped_operating_points_name_shipped_models_and_detector_options():
    """The card file as shipped: every entry a shipped model, every value a valid option."""
    from symgrasp.detect import PRETRAINED, pretrained

    for name, point in pretrained._read_operating_points().items():
        assert name in PRETRAINED
        assert set(point) <= {*pretrained.OPERATING_POINT_KEYS, "chosen"}
        GraspDetector.from_pretrained(name, device="cpu")  # its options pass the checks
