"""Depth as real sensors give it, through the detection path: 16-bit PNGs in millimetres or
other units of a depth scale, invalid zeros, holes at object edges (and ``fill_holes``)."""

import numpy as np
import pytest

from symgrasp.detect import GraspDetector
from symgrasp.detect.files import load_depth, save_png_depth
from symgrasp.perception import CameraIntrinsic, default_extrinsic, table_depth_scale
from symgrasp.perception.points import edge_holes
from symgrasp.sim.objects import object_set
from symgrasp.sim.render import make_renderer
from symgrasp.sim.world import pile_scene
from symgrasp.workspace import TABLE_HEIGHT

SMALL = CameraIntrinsic().scaled(0.5)  # 320 × 240
T = default_extrinsic()


@pytest.fixture(scope="module")
def detector():
    return GraspDetector.from_pretrained("bingham2d-robotiq-2f85", device="cpu")


@pytest.fixture(scope="module")
def depth(detector):
    world = pile_scene(object_set("household-test", 5, seed=0), seed=0, gripper=detector.gripper)
    return make_renderer(SMALL).render(world, T)


def _near(grasp, grasps, voxels=1, degrees=25.0) -> bool:
    return any(
        max(abs(np.subtract(grasp.voxel, other.voxel))) <= voxels
        and grasp.approach @ other.approach >= np.cos(np.radians(degrees))
        for other in grasps
    )


@pytest.mark.parametrize("scale", [0.001, 0.0001])  # millimetres; 0.1 mm (e.g. RealSense D405)
def test_a_16_bit_png_with_its_depth_scale_gives_the_metres_grasps(
    detector, depth, scale, tmp_path
):
    path = save_png_depth(tmp_path / "depth.png", depth, png_scale=scale)
    read = load_depth(path, png_scale=scale)
    assert np.abs(read - depth).max() <= scale / 2 + 1e-6  # rounding to the unit, no more
    expected = detector.detect(depth, SMALL, T)
    got = detector.detect(read, SMALL, T)
    assert len(got) == len(expected) >= 2
    assert all(_near(g, expected) for g in got)


def test_zeros_in_a_png_are_missing_pixels_like_nan(detector, depth, tmp_path):
    holed = depth.copy()
    holed[60:120, 100:200] = 0.0  # a patch the sensor did not measure, on the pile
    path = save_png_depth(tmp_path / "depth.png", holed)
    read = load_depth(path)
    assert (read[60:120, 100:200] == 0).all()
    as_nan = np.where(holed > 0, np.round(depth * 1000) / 1000, np.nan).astype(np.float32)
    assert np.array_equal(
        detector.fuse(read, SMALL, T).grid(), detector.fuse(as_nan, SMALL, T).grid()
    )
    got = [g.voxel for g in detector.detect(read, SMALL, T)]
    assert got == [g.voxel for g in detector.detect(as_nan, SMALL, T)]
    # a voxel whose only view is a missing pixel is unobserved: weight 0, read as free (1)
    volume = detector.fuse(read, SMALL, T)
    seen_before = detector.fuse(depth, SMALL, T).weight > 0
    lost = seen_before & (volume.weight == 0)
    assert lost.any() and (volume.tsdf[lost] == 1).all()


def test_filling_edge_holes_brings_the_tsdf_back_towards_the_whole_images(detector, depth):
    """Against the TSDF of the image without holes, filling them (farthest neighbour first)
    at least halves the voxels that are off by more than half the truncation."""
    holed = edge_holes(depth)
    assert 0.02 < np.mean((holed == 0) & (depth > 0)) < 0.2
    whole = detector.fuse(depth, SMALL, T).grid()
    off = {}
    for pixels in (0, 2):
        filling = GraspDetector(detector.model, detector.gripper, fill_holes=pixels, device="cpu")
        off[pixels] = int(((filling.fuse(holed, SMALL, T).grid() - whole).abs() > 0.5).sum())
    assert off[2] < off[0] / 2
    with pytest.raises(ValueError, match="fill_holes"):
        GraspDetector(detector.model, detector.gripper, fill_holes=-1)


def test_a_depth_scale_error_is_undone_by_the_table_and_only_with_table_scale(detector, depth):
    """A 3 % depth scale error (the dex noise's factor at 1 SD) moves the TSDF; with
    ``table_scale`` the detector fuses the true image again (to float rounding), and leaves a
    true image as it is."""
    calibrated = GraspDetector(detector.model, detector.gripper, table_scale=True, device="cpu")
    true = detector.fuse(depth, SMALL, T).grid()
    off = detector.fuse(1.03 * depth, SMALL, T).grid()
    assert (off - true).abs().max() > 0.5
    back = calibrated.fuse(1.03 * depth, SMALL, T).grid()
    assert (back - true).abs().max() < 1e-3
    assert (calibrated.fuse(depth, SMALL, T).grid() - true).abs().max() < 1e-3
    with pytest.raises(TypeError, match="table_scale"):
        GraspDetector(detector.model, detector.gripper, table_scale=1)


def test_a_depth_scale_read_once_corrects_as_the_table_read_in_every_image(detector, depth):
    """``depth_scale`` divides by a known factor: the true image's TSDF again (to float
    rounding), and with the factor the table gives, exactly ``table_scale``'s TSDF."""
    true = detector.fuse(depth, SMALL, T).grid()
    known = GraspDetector(detector.model, detector.gripper, depth_scale=1.03, device="cpu")
    assert (known.fuse(1.03 * depth, SMALL, T).grid() - true).abs().max() < 1e-3
    read = table_depth_scale(1.03 * depth, SMALL, T, TABLE_HEIGHT)  # workspace origin at 0
    assert abs(read - 1.03) < 1e-3
    once = GraspDetector(detector.model, detector.gripper, depth_scale=read, device="cpu")
    each = GraspDetector(detector.model, detector.gripper, table_scale=True, device="cpu")
    assert once.fuse(1.03 * depth, SMALL, T).grid().equal(each.fuse(1.03 * depth, SMALL, T).grid())


@pytest.mark.parametrize(
    ("options", "error", "match"),
    [
        ({"depth_scale": 1.0, "table_scale": True}, ValueError, "choose one"),
        ({"depth_scale": 1000.0}, ValueError, "depth_scale .* another unit than metres"),
        ({"depth_scale": 0.5}, ValueError, "1 ± 0.2"),
        ({"depth_scale": float("nan")}, ValueError, "depth_scale"),
        ({"depth_scale": True}, TypeError, "depth_scale"),
        ({"depth_scale": "1.03"}, TypeError, "depth_scale"),
    ],
)
def test_a_depth_scale_that_is_no_scale_error_is_refused(detector, options, error, match):
    with pytest.raises(error, match=match):
        GraspDetector(detector.model, detector.gripper, device="cpu", **options)
