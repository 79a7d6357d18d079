"""`GraspDetector.detect_points` against the depth-image path on the same rendered scene, and
the grasps of a fitted table (`symgrasp.perception.fit_table`) taken to the world."""

import warnings

import numpy as np
import pytest

from symgrasp.detect import GraspDetector, NoGraspWarning
from symgrasp.perception import CameraIntrinsic, default_extrinsic, depth_to_points, fit_table
from symgrasp.sim.objects import object_set
from symgrasp.sim.render import make_renderer
from symgrasp.sim.world import pile_scene

SMALL = CameraIntrinsic().scaled(0.5)  # 320 × 240


@pytest.fixture(scope="module")
def detector():
    return GraspDetector.from_pretrained("bingham2d-robotiq-2f85", device="cpu")


@pytest.fixture(scope="module")
def scene(detector):
    world = pile_scene(object_set("household-test", 5, seed=0), seed=0, gripper=detector.gripper)
    T = default_extrinsic()
    depth = make_renderer(SMALL).render(world, T)
    cloud = depth_to_points(depth, SMALL, T, crop=False)
    return depth, T, cloud[np.random.default_rng(0).permutation(len(cloud))]


def _quiet(call):
    with warnings.catch_warnings():
        warnings.simplefilter("error", NoGraspWarning)
        return call()


def _near(grasp, grasps, voxels=1, degrees=25.0) -> bool:
    """Whether a grasp of ``grasps`` lies within ``voxels`` (Chebyshev) of ``grasp`` with an
    approach axis within ``degrees`` of its."""
    return any(
        max(abs(np.subtract(grasp.voxel, other.voxel))) <= voxels
        and grasp.approach @ other.approach >= np.cos(np.radians(degrees))
        for other in grasps
    )


def test_a_cloud_with_its_cameras_intrinsic_gives_the_depth_images_grasps(detector, scene):
    depth, T, cloud = scene
    expected = detector.detect(depth, SMALL, T)
    assert len(expected) >= 2  # the oracle has something to match
    for points, frame in ((cloud, "world"), ((cloud - T[:3, 3]) @ T[:3, :3], "camera")):
        got = _quiet(
            lambda p=points, f=frame: detector.detect_points(p, T, intrinsic=SMALL, frame=f)
        )
        assert [g.voxel for g in got] == [g.voxel for g in expected]
        assert np.allclose([g.pose for g in got], [g.pose for g in expected], atol=1e-5)
        assert np.allclose([g.score for g in got], [g.score for g in expected], atol=1e-4)
    assert set(detector.timing) == {"tsdf", "network", "decode"}


@pytest.mark.parametrize("how", ["pose", "viewpoint", "an eighth of the points"])
def test_a_cloud_on_a_virtual_camera_finds_the_same_grasps_within_a_voxel(detector, scene, how):
    depth, T, cloud = scene
    expected = detector.detect(depth, SMALL, T)
    if how == "viewpoint":
        got = detector.detect_points(cloud, viewpoint=T[:3, 3])
    else:
        got = detector.detect_points(cloud[:: 8 if how.startswith("an eighth") else 1], T)
    assert len(got) == len(expected)
    assert all(_near(g, expected) for g in got)


def test_a_cloud_the_camera_cannot_see_says_why(detector, scene):
    _, T, cloud = scene
    camera_frame = (cloud - T[:3, 3]) @ T[:3, :3]
    with pytest.warns(
        NoGraspWarning, match=r"none of the \d+ finite points lies in the camera's view.*frame="
    ):
        assert detector.detect_points(camera_frame, T) == []  # frame="camera" forgotten
    outside = cloud[cloud[:, 0] > 0.31]  # the table between the camera and the workspace
    with pytest.warns(NoGraspWarning, match=r"lies inside the workspace.*frame it is in"):
        assert detector.detect_points(outside, T) == []
    with pytest.warns(NoGraspWarning, match="none of the 4 points is finite"):
        assert detector.detect_points(np.full((4, 3), np.nan), T) == []


def test_grasps_on_a_fitted_table_are_the_world_frames_after_the_move(detector, scene):
    """Detected in the fitted workspace's frame and moved by ``T_world_camera @
    T_camera_workspace``, the grasps sit on the objects: each TCP within 2 cm of a seen
    object point."""
    depth, T, cloud = scene
    fit = fit_table(depth, SMALL)
    grasps = detector.detect(depth, SMALL, fit.T_workspace_camera)
    assert grasps
    on_objects = cloud[cloud[:, 2] > 0.06]
    for grasp in grasps:
        moved = grasp.transformed(T @ fit.T_camera_workspace)
        assert moved.score == grasp.score and moved.voxel == grasp.voxel
        assert np.linalg.norm(on_objects - moved.position, axis=1).min() < 0.02
        assert np.allclose(moved.pose[:3, :3] @ moved.pose[:3, :3].T, np.eye(3), atol=1e-9)
    with pytest.raises(ValueError, match="T_frame_world must be 4×4"):
        grasps[0].transformed(np.eye(3))
