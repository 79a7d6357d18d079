"""The workspace found by itself (`symgrasp.perception.fit_table`): the table plane and the cube
on it, recovered from depth images of simulated piles taken by tilted, shifted and rolled
cameras, and from analytic scenes: planes, and boxes ray-cast here (a table above a floor, a
grating, a heap of boxes with no table)."""

import math
import warnings

import numpy as np
import pytest

from symgrasp.perception import (
    CameraIntrinsic,
    TableWarning,
    add_depth_noise,
    fit_table,
    look_at,
    table_depth_scale,
)
from symgrasp.perception.table import MAX_SCALE_ERROR, _densest_window, table_scaled
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
    with warnings.catch_warnings():
        warnings.simplefilter("error", TableWarning)  # a table in view: no doubt
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
    with pytest.warns(TableWarning, match=r"holds 18% .*\(no dominant plane\)"):  # mostly wall
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


def _box(centre, half, yaw=0.0, R=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A box: its centre (3,) [m, world], rotation (3, 3) (``yaw`` [rad] about z unless ``R``)
    and half sizes (3,) [m]."""
    if R is None:
        R = np.array(
            [[math.cos(yaw), -math.sin(yaw), 0], [math.sin(yaw), math.cos(yaw), 0], [0, 0, 1]]
        )
    return np.asarray(centre, dtype=float), np.asarray(R, dtype=float), np.asarray(half, float)


def _boxes_depth(T: np.ndarray, boxes: list) -> np.ndarray:
    """The depth SMALL sees from ``T`` of the nearest of ``boxes`` (`_box`), ray cast by the
    slab method in each box's frame; 0 where a ray meets none."""
    rays = SMALL.pixel_rays() @ T[:3, :3].T  # world directions, camera z = 1: t is the depth
    depth = np.full(rays.shape[:2], np.inf)
    for centre, R, half in boxes:
        eye, along = R.T @ (T[:3, 3] - centre), rays @ R
        with np.errstate(divide="ignore", invalid="ignore"):
            t1, t2 = (-half - eye) / along, (half - eye) / along
        enter = np.nanmax(np.minimum(t1, t2), axis=-1)
        leave = np.nanmin(np.maximum(t1, t2), axis=-1)
        depth = np.where((enter <= leave) & (enter > 0) & (enter < depth), enter, depth)
    return np.where(np.isfinite(depth), depth, 0.0)


TOP = 0.75
"""[m] a kitchen table's top above the floor, 1 m × 0.6 m on four legs."""
FLOOR = [_box((0.0, 0.0, -0.5), (10.0, 10.0, 0.5))]
TABLE = [_box((0.0, 0.0, TOP - 0.015), (0.5, 0.3, 0.015))] + [
    _box((x, y, (TOP - 0.03) / 2), (0.025, 0.025, (TOP - 0.03) / 2))
    for x in (-0.45, 0.45)
    for y in (-0.25, 0.25)
]
OBJECTS = [  # the first 12 cm tall, its top 30 cm × 20 cm: a large plane above the table
    _box((0.05, 0.02, TOP + 0.06), (0.15, 0.1, 0.06), 0.3),
    _box((-0.12, -0.1, TOP + 0.04), (0.03, 0.05, 0.04), 1.0),
    _box((-0.1, 0.12, TOP + 0.09), (0.03, 0.03, 0.09), 0.2),
    _box((0.2, -0.12, TOP + 0.025), (0.04, 0.04, 0.025), 0.7),
    _box((0.44, 0.05, TOP + 0.04), (0.03, 0.03, 0.04), 0.4),  # at the edge
]


def _around_the_table(azimuth, distance, elevation, offset) -> np.ndarray:
    """``T_world_camera`` at ``distance`` [m] from a point ``offset`` (along, across) [m]
    from the table's centre, ``elevation`` [rad] above the table, from ``azimuth`` [rad]."""
    c, s = math.cos(azimuth), math.sin(azimuth)
    target = np.array([offset[0] * c - offset[1] * s, offset[0] * s + offset[1] * c, TOP])
    return look_at(
        target - distance * np.array(
            [math.cos(elevation) * c, math.cos(elevation) * s, -math.sin(elevation)]
        ),
        target,
    )  # fmt: skip


@pytest.mark.parametrize("azimuth", [0.0, 1.2, 2.5, 3.6])
@pytest.mark.parametrize(
    ("distance", "elevation", "offset"),
    [(1.0, 0.9, (0.0, 0.0)), (1.6, 0.6, (0.2, 0.0)), (1.3, 0.5, (0.35, 0.1))],
)
@pytest.mark.parametrize("told_up", [False, True])
def test_the_table_is_chosen_above_a_larger_floor_and_below_a_large_box(
    azimuth, distance, elevation, offset, told_up
):
    """A table with objects seen from 12 poses: the floor past its edges fills more of the
    image than the table (the largest plane), the large box's top is a plane above it; the
    fit is the table top (the oracle: the scene's own planes), the floor a competing plane, and
    no doubt is raised."""
    T = _around_the_table(azimuth, distance, elevation, offset)
    depth = _boxes_depth(T, FLOOR + TABLE + OBJECTS)
    up = T[:3, :3].T @ [0.0, 0.0, 1.0] if told_up else None
    with warnings.catch_warnings():
        warnings.simplefilter("error", TableWarning)
        fit = fit_table(depth, SMALL, up=up)
    normal = T[:3, :3] @ fit.normal  # world frame
    assert normal[2] > math.cos(math.radians(0.1))
    assert T[2, 3] - fit.distance * normal[2] == pytest.approx(TOP, abs=0.001)
    heights = [T[2, 3] - p.distance * (T[:3, :3] @ p.normal)[2] for p in fit.competing]
    floor = fit.competing[int(np.argmin(np.abs(heights)))]
    assert abs(min(heights, key=abs)) < 0.001 and floor.inliers > fit.inliers
    assert fit.doubts == () and fit.below < 0.01 * fit.points
    assert fit.centred_on == "cluster"
    centre = T[:3, :3] @ fit.centre + T[:3, 3]
    assert abs(centre[0]) < 0.5 and abs(centre[1]) < 0.3  # on the table top


@pytest.mark.parametrize(
    ("eye", "target"),
    [((0.0, 0.0, 1.4), (0.55, 0.0, TOP)), ((0.3, 0.0, 1.4), (0.8, 0.0, 0.6))],
)
def test_a_table_seen_at_its_edge_is_the_table_with_an_object_in_the_cube(eye, target):
    """The table's edge across the image, the floor beyond it most of the rest (84 % of the
    points in the second view, the table 15 %): the table is chosen without doubt (the share
    counts the points off the floor) and the cube holds an object's centre."""
    T = look_at(np.array(eye), np.array(target))
    depth = _boxes_depth(T, FLOOR + TABLE + OBJECTS)
    with warnings.catch_warnings():
        warnings.simplefilter("error", TableWarning)
        fit = fit_table(depth, SMALL)
    assert T[2, 3] - fit.distance * (T[:3, :3] @ fit.normal)[2] == pytest.approx(TOP, abs=0.001)
    centre = T @ fit.T_camera_workspace @ np.r_[CENTRE, 1.0]
    assert any((np.abs(box[0][:2] - centre[:2]) < WORKSPACE_SIZE / 2).all() for box in OBJECTS)


def _rotation(rng: np.random.Generator) -> np.ndarray:
    """A uniformly random rotation (3, 3): a random unit quaternion's."""
    w, x, y, z = (q := rng.normal(size=4)) / np.linalg.norm(q)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])  # fmt: skip


def _heap(seed: int) -> list:
    """60 boxes of 3–10 cm, turned at random, over a 40 × 40 × 30 cm region above z = 0.55 m
    and nothing under them: no table in view."""
    rng = np.random.default_rng(seed)
    return [
        _box(rng.uniform([-0.2, -0.2, 0.55], [0.2, 0.2, 0.85]), rng.uniform(0.015, 0.05, 3),
             R=_rotation(rng))
        for _ in range(60)
    ]  # fmt: skip


HEAP_VIEWS = {"side": (0.0, -0.4, 1.4), "oblique": (0.3, 0.2, 1.3)}


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("view", HEAP_VIEWS)
@pytest.mark.parametrize("told_up", [False, True])
def test_no_table_in_view_is_refused_or_doubted_aloud(seed, view, told_up):
    """A heap of boxes and no table: whatever plane is fitted holds far less than a table
    would (6–17 % of the points) and fit_table warns in one line, saying so; with ``up`` it
    may instead find no plane level enough and refuse."""
    T = look_at(np.array(HEAP_VIEWS[view]), np.array([0.0, 0.0, 0.7]))
    up = T[:3, :3].T @ [0.0, 0.0, 1.0] if told_up else None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            fit = fit_table(_boxes_depth(T, _heap(seed)), SMALL, up=up)
        except ValueError as error:
            assert told_up and "no plane candidate within 10° of up" in str(error)
            return
    (warning,) = [w for w in caught if w.category is TableWarning]
    assert "no dominant plane" in str(warning.message) and "\n" not in str(warning.message)
    assert fit.share < 0.2 and fit.doubts


def test_a_grating_with_the_floor_seen_through_it_is_doubted():
    """A tabletop of 2 cm slats 2 cm apart in a frame: the floor is seen through it, over the
    plane's extent, which no table allows."""
    slats = [_box((x, 0.0, TOP - 0.015), (0.01, 0.3, 0.015)) for x in np.arange(-0.48, 0.5, 0.04)]
    frame = [_box((0.0, y, TOP - 0.015), (0.5, 0.02, 0.015)) for y in (-0.3, 0.3)]
    T = _around_the_table(0.5, 1.0, 1.1, (0.0, 0.0))
    with pytest.warns(TableWarning, match="seen through it"):
        fit = fit_table(_boxes_depth(T, FLOOR + slats + frame), SMALL)
    assert T[2, 3] - fit.distance * (T[:3, :3] @ fit.normal)[2] == pytest.approx(TOP, abs=0.001)
    assert fit.below > 0.1 * fit.points


def test_a_steep_table_against_up_is_refused():
    """``up`` 15° off the table's normal (a wrong extrinsic): no plane within the default
    10° tolerance, refused in one line; with the tolerance widened, the table."""
    T = _around_the_table(0.0, 1.0, 0.9, (0.0, 0.0))
    depth = _boxes_depth(T, FLOOR + TABLE + OBJECTS)
    tilt = math.radians(15)
    up = T[:3, :3].T @ [math.sin(tilt), 0.0, math.cos(tilt)]
    with pytest.raises(ValueError, match="no plane candidate within 10° of up"):
        fit_table(depth, SMALL, up=up)
    fit = fit_table(depth, SMALL, up=up, max_tilt=math.radians(20))
    assert (T[:3, :3] @ fit.normal)[2] > math.cos(math.radians(0.1))


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


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_depth_scale_with_no_table_in_view_is_refused_not_read_off_the_objects(seed):
    """A heap of boxes and no table, the table said to be 5 cm below the heap's densest
    surface: a scale within MAX_SCALE_ERROR would be read off the boxes (the oracle: the
    densest 1 cm window of heights, sorted and counted here), but the window holds under 15 % of
    the pixels, no table's share, and the image is refused, in table_scaled as well."""
    T = look_at(np.array(HEAP_VIEWS["side"]), np.array([0.0, 0.0, 0.7]))
    depth = _boxes_depth(T, _heap(seed))
    seen = depth > 0
    below = np.sort(-(depth[seen][:, None] * SMALL.pixel_rays()[seen]) @ T[2, :3])
    inside = np.searchsorted(below, below + 0.01, side="right") - np.arange(len(below))
    densest = below[int(np.argmax(inside))]  # [m] below the camera along up
    table_z = T[2, 3] - densest - 0.05
    assert abs(densest / (T[2, 3] - table_z) - 1) < MAX_SCALE_ERROR
    assert inside.max() < 0.15 * len(below)
    with pytest.raises(ValueError, match=r"holds \d+% of the seen pixels, under MIN_TABLE_SHARE"):
        table_depth_scale(depth, SMALL, T, table_z)
    with pytest.raises(ValueError, match="MIN_TABLE_SHARE"):
        table_scaled(depth[None], SMALL, T[None], table_z)


@pytest.mark.parametrize("seed", range(6))
def test_the_densest_window_is_the_one_sorting_and_counting_every_window_finds(seed):
    """`table_depth_scale` counts only the few thousand heights near the densest window;
    the oracle sorts them all and counts every window (the first of the densest, as ties go),
    on heights with a table peak, objects, far outliers and ties (heights rounded to 0.1 mm),
    to the bit."""
    rng = np.random.default_rng(seed)
    heights = np.r_[rng.normal(0.6, 0.003, 3000), rng.uniform(0.3, 0.6, 2000), [30.0, -2.0]]
    if seed % 2:
        heights = np.round(heights, 4)
    rng.shuffle(heights)
    for band in (0.01, 0.001, 1e-9):
        ordered = np.sort(heights)
        inside = np.searchsorted(ordered, ordered + band, side="right") - np.arange(len(ordered))
        start = int(np.argmax(inside))
        assert _densest_window(heights, band) == (ordered[start], inside[start])
