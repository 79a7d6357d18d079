"""Camera, depth rendering and TSDF fusion against analytic scenes."""

import numpy as np
import pytest
import torch
from scipy.spatial import cKDTree

from symgrasp.perception import (
    CameraIntrinsic,
    TSDFVolume,
    add_depth_noise,
    default_extrinsic,
    depth_to_points,
    look_at,
    surface_points,
)
from symgrasp.sim import FRANKA, World
from symgrasp.sim.objects import ObjectSpec, Part
from symgrasp.sim.render import GLRenderer, RaycastRenderer, gl_available, make_renderer
from symgrasp.workspace import TABLE_HEIGHT

SMALL = CameraIntrinsic(160, 120, 135.0, 135.0, 79.5, 59.5)


def _box_world() -> World:
    box = ObjectSpec("b", "box", (Part("box", (0.03, 0.04, 0.05), (0, 0, 0.05)),), 0.2, 0.8)
    T = np.eye(4)
    T[:3, 3] = (0.15, 0.15, TABLE_HEIGHT)
    return World([box], T[None], gripper=FRANKA)


def test_look_at_points_the_optical_axis_at_the_target_with_image_down_toward_minus_z():
    T = look_at((1.0, 0.0, 1.0), (0.0, 0.0, 0.0))
    np.testing.assert_allclose(T[:3, 2], np.array([-1.0, 0.0, -1.0]) / np.sqrt(2))
    assert T[2, 1] < 0  # camera y (image down) points down in the world
    np.testing.assert_allclose(T[:3, :3] @ T[:3, :3].T, np.eye(3), atol=1e-12)
    with pytest.raises(ValueError, match="up"):
        look_at((0, 0, 1), (0, 0, 0))


def test_depth_to_points_inverts_the_projection_and_crops_to_the_workspace():
    rng = np.random.default_rng(0)
    T = default_extrinsic()
    points = rng.uniform(0.02, 0.28, (50, 3))  # inside the workspace
    camera = (points - T[:3, 3]) @ T[:3, :3]  # T⁻¹ applied to each point
    u = SMALL.fx * camera[:, 0] / camera[:, 2] + SMALL.cx
    v = SMALL.fy * camera[:, 1] / camera[:, 2] + SMALL.cy
    depth = np.zeros((SMALL.height, SMALL.width))
    pixels = np.round(u).astype(int), np.round(v).astype(int)
    keep = np.unique(pixels[1] * SMALL.width + pixels[0], return_index=True)[1]
    depth[pixels[1][keep], pixels[0][keep]] = camera[keep, 2]
    back = depth_to_points(depth, SMALL, T)
    # rounding to the pixel centre moves a point by < ½ px · depth / f across the ray
    error = np.linalg.norm(back[:, None] - points[None, keep], axis=-1).min(1)
    assert len(back) == len(keep) and error.max() < 0.5 * np.sqrt(2) * 0.8 / SMALL.fx
    depth[0, 0] = 5.0  # far behind the workspace: cropped, unless asked not to
    assert len(depth_to_points(depth, SMALL, T)) == len(keep)
    assert len(depth_to_points(depth, SMALL, T, crop=False)) == len(keep) + 1
    with pytest.raises(ValueError, match="depth must have shape"):
        depth_to_points(depth.T, SMALL, T)


def test_raycast_depth_of_the_table_seen_straight_down_is_the_camera_height():
    world = World([])
    T = look_at((0.15, 0.15, 0.6), (0.15, 0.15, 0.0), up=(1.0, 0.0, 0.0))
    depth = RaycastRenderer(SMALL).render(world, T)
    np.testing.assert_allclose(depth, 0.6 - TABLE_HEIGHT, atol=1e-6)


def test_raycast_sees_the_box_top_and_not_the_hand():
    world = _box_world()
    hand = np.eye(4)
    hand[:3, 3] = (0.15, 0.15, 0.4)
    world.set_hand_pose(hand)  # right between the camera and the box
    T = look_at((0.15, 0.15, 0.6), (0.15, 0.15, 0.0), up=(1.0, 0.0, 0.0))
    depth = RaycastRenderer(SMALL).render(world, T)
    assert depth[59, 79] == pytest.approx(0.6 - TABLE_HEIGHT - 0.1, abs=1e-6)


@pytest.mark.skipif(not gl_available(), reason="no OpenGL backend (EGL/OSMesa) here")
def test_gl_and_raycast_depth_agree():
    world = _box_world()
    intrinsic = CameraIntrinsic(160, 120, 135.0, 135.0, 70.0, 65.0)  # off-centre principal point
    T = default_extrinsic()
    gl = GLRenderer(intrinsic).render(world, T)
    ray = RaycastRenderer(intrinsic).render(world, T)
    both = (gl > 0) & (ray > 0)
    assert both.mean() > 0.5
    assert np.mean((gl > 0) != (ray > 0)) < 0.01  # same silhouettes, up to edge pixels
    assert np.median(np.abs(gl - ray)[both]) < 1e-3


@pytest.mark.skipif(not gl_available(), reason="no OpenGL backend (EGL/OSMesa) here")
def test_depth_contexts_without_multisampling_see_what_picture_contexts_see():
    # Depth contexts drop the model's multisampling and shadow map (their cost, not their
    # depth); the model keeps its settings for pictures and physics.
    from symgrasp.objects.sets import make_scene

    world, T = make_scene("pile", "household-test", 5, 3), default_extrinsic()
    quality = world.model.vis.quality
    before = quality.offsamples, quality.shadowsize
    assert before[0] > 0 and before[1] > 0  # the picture settings are there to drop
    renderer, painter = GLRenderer(SMALL), GLRenderer(SMALL, pictures=True)
    depth, picture = renderer.render(world, T), painter.render(world, T)
    assert (quality.offsamples, quality.shadowsize) == before
    made = [(r._renderer._mjr_context.offSamples, r._renderer._mjr_context.shadowSize)
            for r in (renderer, painter)]  # fmt: skip
    assert made == [(0, 0), before]
    assert (depth > 0).mean() > 0.5
    assert np.mean((depth > 0) != (picture > 0)) < 0.01  # edge pixels at most
    both = (depth > 0) & (picture > 0)
    assert np.median(np.abs(depth - picture)[both]) < 1e-4


@pytest.mark.skipif(not gl_available(), reason="no OpenGL backend (EGL/OSMesa) here")
@pytest.mark.parametrize("tight", ["model-sized", "full after one geom"])
def test_a_tight_gl_scene_draws_what_mujocos_default_scene_draws(monkeypatch, tight):
    # The renderer's scene holds the model's geoms and a margin instead of 10 000; a scene that
    # fills up is drawn again in a roomy one, so the depth never loses a geom either way.
    from symgrasp.objects.sets import make_scene
    from symgrasp.sim import render

    world, T = make_scene("pile", "household-test", 5, 3), default_extrinsic()
    monkeypatch.setattr(render, "SCENE_MARGIN", render.ROOMY_SCENE)
    roomy = GLRenderer(SMALL).render(world, T)
    monkeypatch.setattr(render, "SCENE_MARGIN", 64 if tight == "model-sized" else 1 - (
        world.model.ngeom + world.model.nsite + world.model.ntendon))  # fmt: skip
    renderer = GLRenderer(SMALL)
    depth = renderer.render(world, T)
    assert (depth > 0).mean() > 0.5
    np.testing.assert_array_equal(depth, roomy)
    expected = render.ROOMY_SCENE if tight == "full after one geom" else world.model.ngeom + 64
    assert renderer._renderer.scene.maxgeom == expected


def _plane_depth(distance: float) -> np.ndarray:
    return np.full((SMALL.height, SMALL.width), distance, dtype=np.float32)


def test_tsdf_of_a_plane_is_the_clipped_signed_distance():
    """Camera above the volume looking down at a plane 0.1 m above the volume's bottom."""
    volume = TSDFVolume()
    eye_height = 0.6
    T = look_at((0.15, 0.15, eye_height), (0.15, 0.15, 0.0), up=(1.0, 0.0, 0.0))
    wide = CameraIntrinsic(160, 120, 40.0, 40.0, 79.5, 59.5)  # sees the whole cube
    volume.integrate(np.full((120, 160), eye_height - 0.1, dtype=np.float32), wide, T)
    z = (torch.arange(40) + 0.5) * volume.voxel_size
    expected = ((z - 0.1) / volume.truncation).clamp(max=1.0)  # + above the plane
    column = volume.grid()[20, 20]
    seen = volume.weight[20, 20] > 0
    assert seen.sum() >= 8  # the band in front of the plane and everything above
    torch.testing.assert_close(column[seen], expected[seen], atol=1e-5, rtol=0)
    assert not seen[z < 0.1 - volume.truncation].any()  # hidden far behind the surface
    points = volume.point_cloud()
    torch.testing.assert_close(points[:, 2], torch.full_like(points[:, 2], 0.1), atol=1e-4, rtol=0)


def test_tsdf_along_the_ray_scales_the_depth_difference_by_the_pixels_ray_length():
    """Open3D's convention (VGN's fusion): the same plane, the distance measured along each
    pixel's ray, √(1 + x̄² + ȳ²) times the depth difference at normalised pixel (x̄, ȳ): a
    column near the optical axis barely changes, one off it stretches."""
    eye_height = 0.6
    T = look_at((0.15, 0.15, eye_height), (0.15, 0.15, 0.0), up=(1.0, 0.0, 0.0))
    wide = CameraIntrinsic(160, 120, 40.0, 40.0, 79.5, 59.5)
    depth = np.full((120, 160), eye_height - 0.1, dtype=np.float32)
    along_z, along_ray = TSDFVolume(), TSDFVolume(along_ray=True)
    along_z.integrate(depth, wide, T)
    along_ray.integrate(depth, wide, T)
    z = (torch.arange(40) + 0.5) * along_ray.voxel_size
    for i, j in ((20, 20), (2, 35)):
        centres = np.stack([np.full(40, (i + 0.5) * 0.0075), np.full(40, (j + 0.5) * 0.0075),
                            z.numpy(), np.ones(40)])  # fmt: skip
        x, y, depth_z = (np.linalg.inv(T) @ centres)[:3]
        u, v = np.round(wide.fx * x / depth_z + wide.cx), np.round(wide.fy * y / depth_z + wide.cy)
        stretch = np.sqrt(1 + ((u - wide.cx) / wide.fx) ** 2 + ((v - wide.cy) / wide.fy) ** 2)
        expected = ((z - 0.1) * torch.as_tensor(stretch) / along_ray.truncation).clamp(max=1.0)
        seen = along_ray.weight[i, j] > 0
        assert seen.sum() >= 8
        torch.testing.assert_close(
            along_ray.grid()[i, j][seen], expected[seen].float(), atol=1e-5, rtol=0
        )
    near_axis = (along_ray.grid()[20, 20] - along_z.grid()[20, 20]).abs().max()
    off_axis = (along_ray.grid()[2, 35] - along_z.grid()[2, 35]).abs().max()
    assert near_axis < 0.01 < 0.1 < off_axis


def test_tsdf_from_rendered_views_has_the_box_inside_and_free_space_outside():
    world = _box_world()
    volume = TSDFVolume()
    renderer = RaycastRenderer(SMALL)
    centre = np.array([0.15, 0.15, 0.15])
    poses = np.stack(
        [
            look_at(centre + 0.5 * np.array([np.cos(a), np.sin(a), 1.0]), centre)
            for a in (0, 2.1, 4.2)
        ]
    )
    depths = np.stack([renderer.render(world, T) for T in poses])
    volume.integrate(depths, SMALL, poses)  # batched over the three views
    grid = volume.grid()

    def at(x, y, z):
        i, j, k = (int(c / volume.voxel_size) for c in (x, y, z))
        return grid[i, j, k].item()

    assert at(0.15, 0.15, TABLE_HEIGHT + 0.095) < 0  # just under the box top
    assert at(0.15, 0.15, TABLE_HEIGHT + 0.14) == pytest.approx(1.0)  # 4 cm above: truncated free
    assert 0 < at(0.15, 0.15, TABLE_HEIGHT + 0.11) < 1  # within the band above the top
    points = volume.point_cloud().numpy()
    on_top = np.abs(points[:, :2] - 0.15).max(axis=1) < 0.02
    assert np.abs(points[on_top, 2] - (TABLE_HEIGHT + 0.1)).max() < 0.004
    assert (volume.weight == 0).any()  # occluded voxels, which the grid alone cannot tell apart
    reference = _observed_crossings(volume)
    assert len(points) == len(reference)
    assert cKDTree(points).query(reference)[0].max() < 1e-6
    corner = np.array([1.0, -2.0, 0.5])
    shifted = surface_points(grid, volume.size, tuple(corner)).numpy()
    np.testing.assert_allclose(shifted, points + corner, atol=1e-6)


def _observed_crossings(volume: TSDFVolume) -> np.ndarray:
    """The zero crossings between neighbouring voxels that both have weight, interpolated: the
    surface a fused volume's weights define, against which the grid alone is checked."""
    tsdf, weight, voxel = volume.tsdf.numpy(), volume.weight.numpy(), volume.voxel_size
    points = []
    for axis in range(3):
        a, b = np.moveaxis(tsdf, axis, 0)[:-1], np.moveaxis(tsdf, axis, 0)[1:]
        wa, wb = np.moveaxis(weight, axis, 0)[:-1], np.moveaxis(weight, axis, 0)[1:]
        crossing = (a * b < 0) & (wa > 0) & (wb > 0) & (np.abs(a) < 1) & (np.abs(b) < 1)
        index = np.argwhere(crossing).astype(np.float32)
        index[:, 0] += (a / (a - b))[crossing]
        order = [axis, *(i for i in range(3) if i != axis)]  # moveaxis's order of the dimensions
        points.append(index[:, np.argsort(order)])
    return (np.concatenate(points) + 0.5) * voxel


def test_tsdf_rejects_mismatched_inputs():
    with pytest.raises(ValueError, match="depth"):
        TSDFVolume().integrate(np.zeros((10, 10)), SMALL, np.eye(4))


def test_depth_noise_is_seeded_and_keeps_holes():
    depth = _plane_depth(0.5)
    depth[:10] = 0
    a, b = add_depth_noise(depth, seed=[1, 2]), add_depth_noise(depth, seed=[1, 2])
    np.testing.assert_array_equal(a, b)
    assert a.dtype == np.float32 and np.all(a[:10] == 0) and np.all(a[10:] > 0)
    assert not np.array_equal(a, add_depth_noise(depth, seed=[1, 3]))


def test_dex_noise_scale_factor_is_gammas_mean_one_and_sd_one_over_root_k():
    # without the field every pixel is depth × g: g read off one pixel of each image
    depth = np.full((4, 4), 0.6, dtype=np.float32)
    g = np.array([add_depth_noise(depth, s, field_probability=0)[0, 0] / 0.6 for s in range(4000)])
    # Gamma(1000, 0.001): mean 1, SD 1/√1000 = 3.16 %; 4 000 draws: SE of the mean 0.05 %
    assert g.mean() == pytest.approx(1.0, abs=0.002)
    assert g.std() == pytest.approx(1 / np.sqrt(1000), rel=0.05)


def test_dex_noise_adds_its_field_to_half_the_images():
    depth = np.full((8, 8), 0.6, dtype=np.float32)
    with_field = [np.ptp(add_depth_noise(depth, seed)) > 0 for seed in range(2000)]
    assert np.mean(with_field) == pytest.approx(0.5, abs=0.045)  # 4 SE of 2 000 draws
    always = [np.ptp(add_depth_noise(depth, s, field_probability=1)) > 0 for s in range(20)]
    assert all(always)


def test_dex_noise_field_has_the_bilinear_closed_form_sd_and_is_smooth():
    """On a 4× grid a pixel's offsets from the grid nodes are 1/8, 3/8, 5/8, 7/8 of a cell, so
    the field's mean square is σ² (mean of (1 − t)² + t² over them)² = (0.65625 σ)². Between
    neighbouring pixels of a row it changes, in three steps of four, by a quarter of the
    difference of two independent grid values (variance σ²/8), in the fourth, across a node, by
    an eighth of the difference of the grid values either side (σ²/32), times the column's
    interpolation (0.65625): a mean square of σ² × 13/128 × 0.65625 (white noise: 2σ²)."""
    depth = np.full((64, 64), 1.0, dtype=np.float32)
    fields = np.stack([
        add_depth_noise(depth, seed, gamma_shape=1e12, field_probability=1) - 1.0
        for seed in range(300)
    ])  # fmt: skip
    interior = fields[:, 2:-2, 2:-2]  # the border's two pixels take the nearest grid value
    assert np.sqrt((interior**2).mean()) == pytest.approx(0.65625 * 0.005, rel=0.03)
    assert abs(interior.mean()) < 2e-4
    step = np.sqrt((np.diff(interior, axis=2) ** 2).mean())
    assert step == pytest.approx(0.005 * np.sqrt(13 / 128 * 0.65625), rel=0.03)
    with pytest.raises(ValueError, match="field_probability"):
        add_depth_noise(depth, field_probability=1.5)
    with pytest.raises(ValueError, match="grid_step"):
        add_depth_noise(depth, grid_step=0)


@pytest.mark.skipif(not torch.cuda.is_available(), reason="no CUDA device here")
def test_tsdf_fusion_on_cuda_matches_cpu():
    T = look_at((0.15, 0.15, 0.6), (0.15, 0.15, 0.0), up=(1.0, 0.0, 0.0))
    depth = _plane_depth(0.45)
    depth[40:80, 60:100] = 0.4  # a step, so the grid is not trivially uniform
    cpu, cuda = TSDFVolume(), TSDFVolume(device="cuda")
    cpu.integrate(depth, SMALL, T)
    cuda.integrate(depth, SMALL, T)
    torch.testing.assert_close(cuda.grid().cpu(), cpu.grid(), atol=1e-5, rtol=0)


def test_renderer_choice_is_automatic_and_reported():
    assert make_renderer(SMALL).name == ("gl" if gl_available() else "raycast")
    assert make_renderer(SMALL, backend="raycast").name == "raycast"
    with pytest.raises(ValueError, match="backend"):
        make_renderer(SMALL, backend="vulkan")
