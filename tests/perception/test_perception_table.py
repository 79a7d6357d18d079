"""The workspace found by itself (`symgrasp.perception.fit_table`): the table plane and the cube
on it, recovered from depth images of simulated piles taken by tilted, shifted and rolled
cameras, and from analytic scenes."""

import math

import numpy as np
import pytest

from symgrasp.perception import (
    CameraIntrinsic,
    add_depth_noise,
    fit_table,
    look_at,
    table_depth_scale,
)
from symgrasp.sim.objects import object_set
from symgrasp.sim.render import make_renderer
from symgrasp.sim.world import pile_scene
from symgrasp.workspace import TABLE_HEIGHT, WORKSPACE_SIZE

SMALL = CameraIntrinsic().scaled(0.25)  # 160 × 120
CENTRE = np.full(3, WORKSPACE_SIZE / 2)


def _camera(distance, polar, azimuth, shift=(0.0, 0.0, 0.0), roll=0.0) -> np.ndarray:
    """``T_world_camera`` at ``distance`` from the workspace centre moved by ``shift``, at
    ``polar`` from the vertical, looking at that point, rolled by ``roll`` about its axis."""
    target = CENTRE + np.asarray(shift)
    eye = target + distance * np.array(
        [math.sin(polar) * math.cos(azimuth), math.sin(polar) * math.sin(azimuth), math.cos(polar)]
    )
    T = look_at(eye, target, (1.0, 0.0, 0.0) if polar < 0.05 else (0.0, 0.0, 1.0))
    turn = np.eye(4)
    turn[:2, :2] = [[math.cos(roll), -math.sin(roll)], [math.sin(roll), math.cos(roll)]]
    return T @ turn


CAMERAS = {
    "side view": _camera(0.6, 0.8, 0.0),
    "steep, shifted, rolled": _camera(0.5, 0.2, 1.0, (0.1, -0.05, -0.1), 0.5),
    "low, far, rolled back": _camera(0.7, 1.0, 2.5, (-0.1, 0.1, -0.1), -1.0),
    "straight down": _camera(0.45, 0.0, 0.0, (0.0, 0.0, -0.1), 0.3),
}


@pytest.fixture(scope="module")
def pile():
    world = pile_scene(object_set("household-test", 5, seed=0), seed=0)
    return world, make_renderer(SMALL)


def _in_world(T_world_camera, fit) -> np.ndarray:
    """``T_world_workspace`` of the fitted cube."""
    return T_world_camera @ fit.T_camera_workspace


@pytest.mark.parametrize("name", CAMERAS)
@pytest.mark.parametrize("noise", [0.0, 0.005])
def test_the_fitted_cube_stands_on_the_table_level_with_the_objects_inside(pile, name, noise):
    """The oracle is the simulator's world frame: its table top is the plane z = TABLE_HEIGHT,
    so the fitted cube's floor must be the world's z = 0 and its z axis the world's +z.
    ``noise``: GIGA's correlated additive depth noise of that standard deviation [m]."""
    world, renderer = pile
    T = CAMERAS[name]
    depth = renderer.render(world, T)
    if noise:
        depth = add_depth_noise(  # the field always, no scale error
            depth, seed=1, gamma_shape=1e12, sigma=noise, field_probability=1
        )
    fit = fit_table(depth, SMALL)
    T_world_workspace = _in_world(T, fit)
    tilt = math.degrees(math.acos(min(1.0, T_world_workspace[2, 2])))
    assert tilt < (0.1 if not noise else 1.0)
    assert abs(T_world_workspace[2, 3]) < (0.0005 if not noise else 0.002)  # the floor [m]
    assert fit.centred_on == "cluster"
    objects = world.object_positions()[:, :2]
    centre = T_world_workspace @ np.r_[CENTRE, 1.0]
    assert np.linalg.norm(centre[:2] - objects.mean(axis=0)) < 0.06  # over the pile
    assert centre[2] == pytest.approx(CENTRE[2], abs=0.002)
    # x points from the centre towards the camera, level
    towards = T[:3, 3] - centre[:3]
    towards[2] = 0.0
    if np.linalg.norm(towards) > 0.05:
        assert T_world_workspace[:3, 0] @ towards / np.linalg.norm(towards) > 0.999
    assert fit.inliers > 0.6 * fit.points


def _planes_depth(T: np.ndarray, planes: list[tuple[np.ndarray, float]]) -> np.ndarray:
    """The depth SMALL sees from ``T`` of the nearest of ``planes`` ``(n, d)``: n·p + d = 0
    (world frame); 0 where a ray meets none in front."""
    rays = SMALL.pixel_rays() @ T[:3, :3].T
    depth = np.full(rays.shape[:2], np.inf)
    for n, d in planes:
        t = -(n @ T[:3, 3] + d) / (rays @ n)
        depth = np.where((t > 0) & (t < depth), t, depth)
    return np.where(np.isfinite(depth), depth, 0.0).astype(np.float32)


def test_an_empty_table_centres_the_cube_where_the_camera_looks():
    T = _camera(0.6, 0.7, 0.4, (0.05, 0.02, -0.1))  # looks at a point of the table top
    fit = fit_table(_planes_depth(T, [(np.array([0.0, 0.0, 1.0]), -TABLE_HEIGHT)]), SMALL)
    assert fit.centred_on == "optical axis"
    target = CENTRE + np.array([0.05, 0.02, -0.1])
    assert np.allclose(T[:3, :3] @ fit.centre + T[:3, 3], target, atol=1e-6)
    assert fit.distance == pytest.approx(T[2, 3] - TABLE_HEIGHT, abs=1e-6)  # the camera's height


def test_around_chooses_the_centre_and_up_rejects_a_larger_wall():
    """A wall nearer than the table fills most of the image: the largest plane, until ``up``
    says which way is up."""
    T = _camera(0.6, 1.2, 0.0)
    wall = (
        np.array([1.0, 0.0, 0.0]),
        -0.3,
    )  # x = 0.3, between the camera and the centre's far side
    depth = _planes_depth(T, [(np.array([0.0, 0.0, 1.0]), -TABLE_HEIGHT), wall])
    walled = fit_table(depth, SMALL)
    assert abs(T[:3, :3] @ walled.normal @ [1.0, 0.0, 0.0]) > 0.999  # the wall won
    up = T[:3, :3].T @ [0.0, 0.0, 1.0]  # the world's up in the camera frame
    fit = fit_table(
        depth, SMALL, up=up, around=T[:3, :3].T @ (np.array([0.1, 0.2, 0.3]) - T[:3, 3])
    )
    # within 1°: the wall's foot lies within the threshold of the table and tilts the refit
    assert (T[:3, :3] @ fit.normal)[2] > math.cos(math.radians(1.0))
    assert fit.centred_on == "around"
    assert T[:3, :3] @ fit.centre + T[:3, 3] == pytest.approx([0.1, 0.2, TABLE_HEIGHT], abs=0.003)


def test_the_same_seed_gives_the_same_fit_and_bad_input_is_refused(pile):
    world, renderer = pile
    depth = add_depth_noise(renderer.render(world, CAMERAS["side view"]), seed=2)
    first, again = fit_table(depth, SMALL, seed=3), fit_table(depth, SMALL, seed=3)
    assert np.array_equal(first.T_camera_workspace, again.T_camera_workspace)
    assert np.allclose(first.T_workspace_camera @ first.T_camera_workspace, np.eye(4))
    cases = [
        (r"depth must have shape \(120, 160\)", lambda: fit_table(depth[1:], SMALL)),
        ("needs seen depth pixels", lambda: fit_table(np.zeros_like(depth), SMALL)),
        ("threshold must be > 0", lambda: fit_table(depth, SMALL, threshold=0)),
        ("up must be a direction", lambda: fit_table(depth, SMALL, up=(0, 0, 0))),
        ("around must be 3 finite numbers", lambda: fit_table(depth, SMALL, around=(0, 1))),
        ("no plane candidate within 5° of up", lambda: fit_table(
            depth, SMALL, up=(1.0, 0.0, 0.0), max_tilt=math.radians(5), iterations=8)),
    ]  # fmt: skip
    for said, call in cases:
        with pytest.raises(ValueError, match=said):
            call()


def _plane_depth(T_world_camera, intrinsic, z) -> np.ndarray:
    """Closed form: the depth (along the optical axis) at which each pixel's ray meets the
    horizontal plane at height ``z`` [m]; 0 where it does not (a ray pointing up)."""
    rays = intrinsic.pixel_rays() @ T_world_camera[:3, :3].T  # world directions, camera z = 1
    with np.errstate(divide="ignore"):
        depth = (z - T_world_camera[2, 3]) / rays[..., 2]
    return np.where(depth > 0, depth, 0.0)


@pytest.mark.parametrize("name", CAMERAS)
def test_the_depth_scale_puts_the_table_back_where_the_world_frame_says(name):
    """Closed form: a table at z = TABLE_HEIGHT with a 6 cm block on it covering a quarter of
    the image, its depth times 1.04 (a 4 % scale error: 1.3 SD of the dex noise's factor),
    gives back 1.04, and the image divided by it is the true one."""
    T = CAMERAS[name]
    true = _plane_depth(T, SMALL, TABLE_HEIGHT)
    block = _plane_depth(T, SMALL, TABLE_HEIGHT + 0.06)
    h, w = true.shape
    true[h // 4 : 3 * h // 4, w // 4 : 3 * w // 4] = block[h // 4 : 3 * h // 4, w // 4 : 3 * w // 4]
    scale = table_depth_scale(1.04 * true, SMALL, T, TABLE_HEIGHT)
    assert scale == pytest.approx(1.04, abs=1e-9)
    np.testing.assert_allclose(1.04 * true / scale, true, atol=1e-12)


def test_the_depth_scale_of_rendered_piles_under_the_dex_noise_is_its_gamma_factor(pile):
    """The dex noise's Gamma factor, drawn first from the noise's seed, is recovered from
    rendered piles to 0.1 % (its SD is 3.2 %) under its smooth field, seen or not."""
    world, renderer = pile
    for seed, name in enumerate(("side view", "steep, shifted, rolled", "low, far, rolled back")):
        T = CAMERAS[name]
        noisy = add_depth_noise(renderer.render(world, T), seed, field_probability=1.0)
        factor = np.random.default_rng(seed).gamma(1000.0, 1 / 1000.0)
        assert table_depth_scale(noisy, SMALL, T, TABLE_HEIGHT) == pytest.approx(factor, abs=1e-3)


def test_a_table_not_where_the_world_frame_says_or_not_seen_is_refused():
    T = CAMERAS["side view"]
    elsewhere = _plane_depth(T, SMALL, TABLE_HEIGHT - 0.3)  # 30 cm lower: no sensor's scale
    with pytest.raises(ValueError, match="max_error"):
        table_depth_scale(elsewhere, SMALL, T, TABLE_HEIGHT)
    with pytest.raises(ValueError, match="above the table"):
        table_depth_scale(elsewhere, SMALL, T, T[2, 3] + 0.1)
    with pytest.raises(ValueError, match="100 seen depth pixels"):
        table_depth_scale(np.zeros_like(elsewhere), SMALL, T, TABLE_HEIGHT)
    with pytest.raises(ValueError, match="shape"):
        table_depth_scale(elsewhere[:10], SMALL, T, TABLE_HEIGHT)
