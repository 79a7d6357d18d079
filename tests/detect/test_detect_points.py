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
    assert set(detector.timing) == {"tsdf", "network", "decode", "cut", "width"}


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


def _write_ply(path, points, fmt="binary_little_endian", extra=""):
    """A PLY file of ``points`` (N, 3) as float32 x, y, z and an 8-bit colour, written here
    by hand (the oracle of `load_points`)."""
    header = (
        f"ply\nformat {fmt} 1.0\ncomment written by a test\nelement vertex {len(points)}\n"
        "property float x\nproperty float y\nproperty float z\nproperty uchar red\n"
        f"{extra}element face 0\nproperty list uchar int vertex_indices\nend_header\n"
    )
    with open(path, "wb") as file:
        file.write(header.encode())
        if fmt == "ascii":
            file.write("".join(f"{x} {y} {z} 7\n" for x, y, z in points).encode())
        else:
            order = "<" if fmt == "binary_little_endian" else ">"
            rows = np.zeros(len(points), dtype=[(a, order + "f4") for a in "xyz"] + [("red", "u1")])
            for i, axis in enumerate("xyz"):
                rows[axis] = points[:, i]
            file.write(rows.tobytes())
    return path


def test_load_points_reads_npy_and_ascii_and_binary_ply(scene, tmp_path):
    from symgrasp.detect.files import load_points

    cloud = scene[2][:500].astype(np.float32)
    np.save(tmp_path / "cloud.npy", cloud)
    assert np.array_equal(load_points(tmp_path / "cloud.npy"), cloud)
    for fmt in ("ascii", "binary_little_endian", "binary_big_endian"):
        read = load_points(_write_ply(tmp_path / f"{fmt}.ply", cloud, fmt))
        assert read.shape == (500, 3) and np.allclose(read, cloud, atol=1e-6), fmt
    organised = np.full((4, 5, 3), np.nan)
    np.save(tmp_path / "organised.npy", organised)
    assert load_points(tmp_path / "organised.npy").shape == (4, 5, 3)
    refused = {
        "nothing.npy": (None, "points: no file at"),
        "cloud.txt": ("x", "must be a .npy or .ply file"),
        "ints.npy": (np.zeros((4, 3), dtype=np.int32), "holds int32 of shape"),
        "pairs.npy": (np.zeros((4, 2)), r"of shape \(4, 2\); a point cloud"),
        "broken.ply": (b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n", "no end_header"),
        "xy.ply": (b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n1 2\n", "x, y, z"),
        "short.ply": (b"ply\nformat binary_little_endian 1.0\nelement vertex 9\nproperty float x\nproperty float y\nproperty float z\nend_header\n\x00", "ends before its 9 vertices"),
        "faces_first.ply": (b"ply\nformat ascii 1.0\nelement face 0\nelement vertex 0\nend_header\n", "first element must be vertex"),
    }  # fmt: skip
    for name, (content, said) in refused.items():
        if isinstance(content, np.ndarray):
            np.save(tmp_path / name, content)
        elif isinstance(content, bytes):
            (tmp_path / name).write_bytes(content)
        elif content is not None:
            (tmp_path / name).write_text(content)
        with pytest.raises(ValueError, match=said) as error:
            load_points(tmp_path / name)
        assert name in str(error.value)


def test_symgrasp_detect_points_writes_the_grasps_of_the_depth_image(detector, scene, tmp_path):
    import json

    from symgrasp.cli import main

    depth, T, cloud = scene
    (tmp_path / "T.json").write_text(json.dumps(T.tolist()))
    K = {"fx": SMALL.fx, "fy": SMALL.fy, "cx": SMALL.cx, "cy": SMALL.cy, "width": SMALL.width,
         "height": SMALL.height}  # fmt: skip
    (tmp_path / "K.json").write_text(json.dumps(K))
    _write_ply(tmp_path / "cloud.ply", cloud.astype(np.float32))
    main(["detect", "--points", str(tmp_path / "cloud.ply"), "--extrinsic", str(tmp_path / "T.json"),
          "--intrinsic", str(tmp_path / "K.json"), "--out", str(tmp_path / "sensor")])  # fmt: skip
    written = json.loads((tmp_path / "sensor" / "grasps.json").read_text())["grasps"]
    expected = detector.detect(depth, SMALL, T)
    assert [tuple(g["voxel"]) for g in written] == [g.voxel for g in expected]
    main(["detect", "--points", str(tmp_path / "cloud.ply"), "--viewpoint", *map(str, T[:3, 3]),
          "--out", str(tmp_path / "virtual")])  # fmt: skip
    virtual = json.loads((tmp_path / "virtual" / "grasps.json").read_text())["grasps"]
    assert len(virtual) == len(expected)
    assert (tmp_path / "virtual" / "grasps.png").stat().st_size > 10_000
    depth_file, pose_file = tmp_path / "d.npy", tmp_path / "T.json"  # existing: the parser checks
    np.save(depth_file, depth)
    pose_file.write_text(json.dumps(T.tolist()))
    for argv, said in (
        (["--points", str(tmp_path / "cloud.ply")], "--points needs --extrinsic or --viewpoint"),
        (["--depth", str(depth_file), "--extrinsic", str(pose_file)], "--depth needs --intrinsic and --extrinsic"),
        (["--points", str(tmp_path / "cloud.ply"), "--viewpoint", "1", "0", "1", "--points-frame", "camera"],
         "--points-frame camera needs --extrinsic"),
    ):  # fmt: skip
        with pytest.raises(SystemExit, match=said):
            main(["detect", *argv, "--out", str(tmp_path / "refused")])
