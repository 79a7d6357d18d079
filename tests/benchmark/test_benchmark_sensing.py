"""What the benchmark's cameras see: the field's camera poses in closed form, random views from
the training distribution, noise drawn from the round and the attempt, the same images for
every planner, and the collision check on the images the planner saw."""

import math

import numpy as np
import pytest

from symgrasp.benchmark import declutter
from symgrasp.benchmark.declutter import run_round
from symgrasp.benchmark.sensing import NOISE, Sensor, draw_seed
from symgrasp.detect import Grasp
from symgrasp.names import NOISES, VIEWS
from symgrasp.objects.sets import make_scene, resolve
from symgrasp.perception import CameraIntrinsic, default_extrinsic
from symgrasp.perception.camera import is_rigid
from symgrasp.sim import FRANKA
from symgrasp.sim.render import make_renderer

SMALL = CameraIntrinsic(160, 120, 135.0, 135.0, 79.5, 59.5)
HOUSEHOLD = resolve("household-test")


def _looks_at(T, target):
    """The camera's optical axis (its z, OpenCV) passes through ``target``."""
    ray = np.asarray(target) - T[:3, 3]
    return np.allclose(np.cross(T[:3, 2], ray / np.linalg.norm(ray)), 0, atol=1e-12)


def _below_horizontal(T) -> float:
    """Degrees the optical axis points below the horizontal."""
    return math.degrees(math.asin(-T[2, 2]))


def test_the_side_view_is_gigas_one_camera_30_degrees_below_horizontal_from_minus_y():
    (T,) = Sensor(view="side").cameras(seed=0, attempt=0)
    # GIGA: r = 2 × 0.3 m, θ = π/3 from the vertical, φ = −π/2, around (0.15, 0.15, 0.3/3)
    eye = (0.15, 0.15 - 0.6 * math.sin(math.pi / 3), 0.10 + 0.6 * math.cos(math.pi / 3))
    np.testing.assert_allclose(T[:3, 3], eye, atol=1e-12)
    np.testing.assert_allclose(T[:3, 3], (0.15, -0.3696, 0.40), atol=1e-4)
    assert _looks_at(T, (0.15, 0.15, 0.10))
    assert _below_horizontal(T) == pytest.approx(30.0)
    assert T[2, 1] < 0  # image down is world down: no roll
    np.testing.assert_allclose(T[:3, :3] @ T[:3, :3].T, np.eye(3), atol=1e-12)


def test_the_circle_is_vgns_views_60_degrees_below_horizontal_evenly_around():
    cameras = Sensor(view="circle", views=6).cameras(seed=0, attempt=0)
    assert cameras.shape == (6, 4, 4)
    for k, T in enumerate(cameras):
        phi = 2 * math.pi * k / 6
        # VGN: r = 0.6 m, θ = π/6 around (0.15, 0.15, 0): 0.3 m out, 0.52 m up
        eye = (0.15 + 0.3 * math.cos(phi), 0.15 + 0.3 * math.sin(phi), 0.6 * math.cos(math.pi / 6))
        np.testing.assert_allclose(T[:3, 3], eye, atol=1e-12)
        assert _looks_at(T, (0.15, 0.15, 0.0))
        assert _below_horizontal(T) == pytest.approx(60.0)
    assert Sensor(view="circle", views=2).cameras(0, 0)[1, 0, 3] == pytest.approx(0.15 - 0.3)


def test_the_fixed_view_is_todays_camera_and_one_camera_views_take_one_image():
    np.testing.assert_array_equal(Sensor().cameras(5, 3), default_extrinsic()[None])
    for view in ("fixed", "side"):
        with pytest.raises(ValueError, match=f"views must be 1 with view '{view}'"):
            Sensor(view=view, views=6)
    with pytest.raises(ValueError, match="noise must be one of"):
        Sensor(noise="gaussian")
    with pytest.raises(ValueError, match="views must be an integer"):
        Sensor(view="circle", views=0)


def test_every_name_the_command_line_offers_is_a_sensor():
    for noise in NOISES:
        for view in VIEWS:
            cameras = Sensor(noise, view).cameras(seed=3, attempt=1)
            assert cameras.shape == (1, 4, 4) and is_rigid(cameras)


def test_random_views_are_the_training_distribution_drawn_from_round_attempt_and_view():
    sensor = Sensor(view="random", views=3)
    cameras = np.concatenate([sensor.cameras(seed, attempt) for seed in range(40)
                              for attempt in range(3)])  # fmt: skip
    centre = np.full(3, 0.15)
    offsets = cameras[:, :3, 3] - centre
    distance = np.linalg.norm(offsets, axis=1)
    polar = np.arccos(offsets[:, 2] / distance)
    assert distance.min() >= 0.45 and distance.max() <= 0.7  # SceneConfig.camera_distance
    assert polar.min() >= 0.1 and polar.max() <= math.pi / 3  # SceneConfig.camera_polar
    assert all(_looks_at(T, centre) for T in cameras)
    np.testing.assert_array_equal(sensor.cameras(7, 2), sensor.cameras(7, 2))
    assert not np.allclose(sensor.cameras(7, 2), sensor.cameras(7, 3))
    assert not np.allclose(sensor.cameras(7, 2), sensor.cameras(8, 2))
    # a view's camera does not depend on how many views there are
    np.testing.assert_array_equal(
        Sensor(view="random", views=1).cameras(7, 2)[0], sensor.cameras(7, 2)[0]
    )


@pytest.fixture(scope="module")
def scene():
    return make_scene("pile", HOUSEHOLD, 3, seed=4, gripper=FRANKA), make_renderer(SMALL)


def test_noise_is_drawn_from_round_attempt_and_view_and_keeps_missing_pixels(scene):
    world, renderer = scene
    clean = Sensor(intrinsic=SMALL, view="circle", views=2).observe(renderer, world, 4, 0)
    noisy = Sensor(noise="dex", intrinsic=SMALL, view="circle", views=2)
    first = noisy.observe(renderer, world, 4, 0)
    np.testing.assert_array_equal(first.depth, noisy.observe(renderer, world, 4, 0).depth)
    np.testing.assert_array_equal(first.T_world_camera, clean.T_world_camera)
    assert not np.array_equal(first.depth, clean.depth)
    seen = clean.depth > 0
    np.testing.assert_array_equal(first.depth > 0, seen)
    ratio = first.depth[seen] / clean.depth[seen]
    assert abs(np.median(ratio) - 1) < 0.15  # one Gamma(1000) factor, SD 3.2 %
    for other in (noisy.observe(renderer, world, 4, 1), noisy.observe(renderer, world, 5, 0)):
        assert not np.array_equal(other.depth, first.depth)


class Recording:
    """A planner that keeps what it was shown and proposes ``grasps``."""

    name, version = "recording", "0"

    def __init__(self, grasps=()):
        self.gripper = FRANKA
        self.grasps = list(grasps)
        self.seen = []

    def plan(self, observation):
        self.seen.append(observation.depth.copy())
        return self.grasps


def test_every_planner_sees_the_same_noisy_images_and_the_collision_check_sees_them_too(
    monkeypatch,
):
    checked = []
    fuse = declutter.fuse

    def recording_fuse(depth, *args):
        checked.append(np.array(depth))
        return fuse(depth, *args)

    monkeypatch.setattr(declutter, "fuse", recording_fuse)
    sensor = Sensor(noise="dex", intrinsic=SMALL)
    idle = Recording()  # proposes nothing: the round ends after its first look
    pose = np.eye(4)
    pose[:3, :3] = [[0, 0, 1], [0, 1, 0], [-1, 0, 0]]  # approach down, closing along x
    pose[:3, 3] = (0.03, 0.03, 0.25)  # in the air over a corner: executed, closes on nothing
    missing = Recording([Grasp(pose, score=1.0)])
    rounds = [run_round(p, HOUSEHOLD, 3, seed=4, sensor=sensor, diagnose=False)
              for p in (idle, missing)]  # fmt: skip
    assert [a.outcome for a in rounds[0].attempts] == ["none_found"]
    assert len(rounds[1].attempts) == 2 and len(missing.seen) == 2  # two failures end it
    np.testing.assert_array_equal(idle.seen[0], missing.seen[0])
    assert not np.array_equal(missing.seen[0], missing.seen[1])  # the next attempt's noise
    assert len(checked) == 3
    for shown, fused in zip([*idle.seen, *missing.seen], checked, strict=True):
        np.testing.assert_array_equal(shown, fused)


def test_the_robot_reads_the_depth_scale_off_its_table_before_anyone_sees_the_images(scene):
    """With ``table_scale`` every planner and the collision check are given the noisy images
    divided by their scale factor: the dex noise's Gamma draw, recovered from the table."""
    world, renderer = scene
    noisy = Sensor(intrinsic=SMALL, noise="dex", view="side")
    calibrated = Sensor(intrinsic=SMALL, noise="dex", view="side", table_scale=True)
    for attempt in (0, 1):
        (seen,) = noisy.observe(renderer, world, 4, attempt).depth
        (given,) = calibrated.observe(renderer, world, 4, attempt).depth
        factor = np.random.default_rng(draw_seed(NOISE, 4, attempt, 0)).gamma(1000.0, 1 / 1000.0)
        ratio = seen[seen > 0] / given[seen > 0]
        assert np.allclose(ratio, ratio[0]) and ratio[0] == pytest.approx(factor, abs=1e-3)
