"""Point clouds as depth images (`symgrasp.perception.points`): the z-buffer rule, the round
trip through a camera's own pixels, the virtual camera, holes made at depth jumps and hole
filling, against closed forms."""

import numpy as np
import pytest
from bad_input_cases import CAMERA, INTRINSIC, table_depth

from symgrasp.perception import CameraIntrinsic, depth_to_points, fill_holes, points_view
from symgrasp.perception.points import (
    DEFAULT_PIXEL_SIZE,
    edge_holes,
    points_depth,
    viewpoint_extrinsic,
    virtual_camera,
)
from symgrasp.workspace import WORKSPACE_SIZE

CAMERA_POINTS = np.array(
    [
        [0.0, 0.0, 0.5],  # pixel (cx, cy) = (32, 24)
        [0.0, 0.0, 0.4],  # the same pixel, nearer: kept
        [0.0, 0.0, 0.6],  # the same pixel, farther: hidden
        [0.2, 0.0, 0.5],  # pixel (52, 24)
        [0.0, 0.0, -0.5],  # behind the camera
        [10.0, 0.0, 0.5],  # right of the image
        [np.nan, 0.0, 0.5],  # a hole of an organised cloud
    ]
)


def test_each_pixel_keeps_the_nearest_point_and_the_rest_is_dropped():
    depth = points_depth(CAMERA_POINTS, INTRINSIC)
    assert depth.shape == (48, 64) and depth.dtype == np.float32
    assert depth[24, 32] == pytest.approx(0.4)
    assert depth[24, 52] == pytest.approx(0.5)  # u = 50 · 0.2 / 0.5 + 32
    assert np.count_nonzero(depth) == 2


def test_a_pixel_is_the_square_around_its_centre_as_the_tsdf_rounds():
    # 0.49 px right of pixel 32's centre still lands in it, 0.51 px in pixel 33
    z = 0.5
    near, far = (np.array([[(du / INTRINSIC.fx) * z, 0.0, z]]) for du in (0.49, 0.51))
    assert points_depth(near, INTRINSIC)[24, 32] == pytest.approx(z)
    assert points_depth(far, INTRINSIC)[24, 33] == pytest.approx(z)


def _cloud(depth):
    """The world points of ``depth`` seen by INTRINSIC from CAMERA, in a random order."""
    points = depth_to_points(depth, INTRINSIC, CAMERA, crop=False)
    return points[np.random.default_rng(0).permutation(len(points))]


def test_a_cloud_seen_by_its_own_camera_is_its_depth_image_again():
    depth = table_depth()
    depth[10:20, 20:30] = 0.0  # a hole stays a hole: nothing is filled with the sensor's camera
    again, intrinsic, T = points_view(_cloud(depth), CAMERA, intrinsic=INTRINSIC)
    assert intrinsic is INTRINSIC and np.array_equal(T, CAMERA)
    assert np.allclose(again, depth, rtol=0, atol=1e-6)
    assert np.array_equal(again > 0, depth > 0)


def test_an_organised_cloud_in_the_camera_frame_gives_the_same_image():
    depth = table_depth()
    depth[5:8] = 0.0
    organised = depth[..., None] * INTRINSIC.pixel_rays()  # camera frame, (H, W, 3)
    organised[depth == 0] = np.nan
    again, _, _ = points_view(organised, CAMERA, intrinsic=INTRINSIC.K, frame="camera")
    assert np.allclose(again, depth, rtol=0, atol=1e-6)


def test_the_virtual_camera_covers_the_workspace_with_pixels_of_the_asked_size():
    camera = virtual_camera(CAMERA)
    corners = WORKSPACE_SIZE * np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)])
    in_camera = (corners - CAMERA[:3, 3]) @ CAMERA[:3, :3]
    u = camera.fx * in_camera[:, 0] / in_camera[:, 2] + camera.cx
    v = camera.fy * in_camera[:, 1] / in_camera[:, 2] + camera.cy
    assert u.min() >= -0.5 and u.max() < camera.width - 0.5
    assert v.min() >= -0.5 and v.max() < camera.height - 0.5
    centre_depth = np.linalg.norm(CAMERA[:3, 3] - WORKSPACE_SIZE / 2)
    assert centre_depth / camera.fx == pytest.approx(DEFAULT_PIXEL_SIZE)
    assert virtual_camera(CAMERA, pixel_size=2 * DEFAULT_PIXEL_SIZE).width < camera.width
    behind = CAMERA.copy()
    behind[:3, :3] = -behind[:3, :3] @ np.diag([1, -1, 1])  # turned round to face away
    with pytest.raises(ValueError, match="behind the camera"):
        virtual_camera(behind)


def test_a_viewpoint_looks_at_the_workspace_centre_even_from_straight_above():
    for eye in ((0.65, 0.15, 0.65), (0.15, 0.15, 0.8)):
        T = viewpoint_extrinsic(eye)
        assert np.allclose(T[:3, 3], eye)
        along = (np.full(3, WORKSPACE_SIZE / 2) - eye) / np.linalg.norm(
            WORKSPACE_SIZE / 2 - np.array(eye)
        )
        assert np.allclose(T[:3, 2], along)
    with pytest.raises(ValueError, match="viewpoint must be 3 finite numbers"):
        viewpoint_extrinsic((0.1, 0.2))


def test_a_sparse_cloud_on_the_virtual_camera_leaves_no_hole_inside_the_table():
    """The table plane from the default camera, sampled on a grid as wide as the virtual
    pixels: every virtual pixel inside it is seen, at the plane's depth."""
    step = DEFAULT_PIXEL_SIZE * 1.5
    x, y = np.meshgrid(np.arange(-0.2, 0.5, step), np.arange(-0.2, 0.5, step))
    table = np.stack([x.ravel(), y.ravel(), np.full(x.size, 0.05)], axis=1)
    depth, camera, T = points_view(table, CAMERA)
    rays = camera.pixel_rays() @ T[:3, :3].T
    plane = (0.05 - T[2, 3]) / rays[..., 2]  # the depth the table has at each pixel
    hits = T[:3, 3] + plane[..., None] * rays
    inside = np.all((hits[..., :2] > -0.19) & (hits[..., :2] < 0.49), axis=-1)
    assert inside.sum() > 1000 and (depth[inside] > 0).all()
    assert np.abs(depth[inside] - plane[inside]).max() < 0.01  # a neighbour's depth at most


def test_fill_holes_takes_the_farthest_neighbour_and_reaches_as_far_as_asked():
    depth = np.full((9, 9), 1.0, dtype=np.float32)
    depth[:, 5:] = 2.0  # a step: the far side at 2 m
    depth[2:7, 3:6] = 0.0  # a hole on the step, 3 px wide
    once = fill_holes(depth, 1)
    assert once[4, 3] == 1.0 and once[4, 5] == 2.0  # the edge of the hole, from each side
    assert once[3, 4] == 0.0 and once[4, 4] == 0.0  # the middle column is 2 px in
    twice = fill_holes(depth, 2)
    assert (twice > 0).all() and twice[4, 4] == 2.0  # the far side wins a tie of reach
    seen = depth > 0
    assert np.array_equal(twice[seen], depth[seen])
    assert np.array_equal(fill_holes(depth, 0), depth)
    with pytest.raises(ValueError, match="pixels must be an integer ≥ 0"):
        fill_holes(depth, -1)


def test_edge_holes_drop_the_pixels_within_their_width_of_a_jump_and_fill_holes_mends_them():
    depth = np.full((9, 12), 1.0, dtype=np.float32)
    depth[:, 6:] = 1.01  # a step under the jump: no edge
    assert np.array_equal(edge_holes(depth, jump=0.02), depth)
    depth[:, 6:] = 1.5  # a step over it, between columns 5 and 6
    for width in (1, 2):
        holed = edge_holes(depth, jump=0.02, width=width)
        dropped = np.flatnonzero((holed == 0).all(axis=0))
        assert list(dropped) == list(range(5 - width, 7 + width))  # both sides of the jump
        assert np.array_equal(holed[holed > 0], depth[holed > 0])
        # each side's width + 1 columns filled from its own side: the step as it was
        assert np.array_equal(fill_holes(holed, width + 1), depth)
        assert not np.array_equal(fill_holes(holed, width), depth)
    with pytest.raises(ValueError, match="width must be an integer ≥ 1"):
        edge_holes(depth, width=0)  # scipy would dilate until nothing changes
    with pytest.raises(ValueError, match="jump must be > 0"):
        edge_holes(depth, jump=0.0)


def test_bad_arguments_are_refused_naming_them():
    cloud = _cloud(table_depth())
    cases = [
        ("exactly one", lambda: points_view(cloud)),
        ("exactly one", lambda: points_view(cloud, CAMERA, viewpoint=(1, 0, 1))),
        ("need T_world_camera", lambda: points_view(cloud, viewpoint=(1, 0, 1), frame="camera")),
        ("frame must be one of world, camera", lambda: points_view(cloud, CAMERA, frame="base")),
        (r"shape \(N, 3\) or organised", lambda: points_view(cloud[:, :2], CAMERA)),
        ("must be real", lambda: points_view(cloud.astype(complex), CAMERA)),
        ("not a rigid transform", lambda: points_view(cloud, 2 * CAMERA)),
        ("must be a CameraIntrinsic", lambda: points_view(cloud, CAMERA, intrinsic=INTRINSIC.K)),
        ("pixel_size must be a positive", lambda: points_view(cloud, CAMERA, pixel_size=0.0)),
    ]
    for said, call in cases:
        with pytest.raises(ValueError, match=said):
            call()
    assert isinstance(points_view(cloud, viewpoint=CAMERA[:3, 3])[1], CameraIntrinsic)
