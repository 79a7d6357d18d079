"""Grasp pictures: outlines match the gripper's dimensions, PNG and HTML files are complete."""

import json
import re

import numpy as np
import pytest
from matplotlib.image import imread

from symgrasp.detect.show import gripper_outline, save_grasps_html, save_grasps_png
from symgrasp.names import GRIPPERS
from symgrasp.sim.grippers import get_gripper

FRANKA = get_gripper("franka")


def _random_pose(rng: np.random.Generator) -> np.ndarray:
    q, r = np.linalg.qr(rng.standard_normal((3, 3)))
    q *= np.sign(np.diag(r))
    T = np.eye(4)
    T[:3, :3] = q * np.linalg.det(q)  # det −1 → +1 by flipping all three columns
    T[:3, 3] = rng.uniform(0.05, 0.25, 3)
    return T


def _scene(grasps: int, points: int = 500, seed: int = 0):
    rng = np.random.default_rng(seed)
    cloud = rng.uniform([0.1, 0.1, 0.05], [0.2, 0.2, 0.15], size=(points, 3))
    poses = np.array([_random_pose(rng) for _ in range(grasps)]).reshape(grasps, 4, 4)
    return cloud, poses, rng.uniform(0, 1, grasps)


@pytest.mark.parametrize("name", GRIPPERS)
def test_identity_outline_has_the_grippers_dimensions(name):
    g = get_gripper(name)
    fingers_pos, fingers_neg, palm_bar, stem = gripper_outline(np.eye(4), g)
    half, tip, palm = g.max_width / 2, g.tip_beyond_tcp, g.tip_beyond_tcp - g.finger_depth
    np.testing.assert_allclose(fingers_pos, [[tip, 0, half], [palm, 0, half]])
    np.testing.assert_allclose(fingers_neg, [[tip, 0, -half], [palm, 0, -half]])
    np.testing.assert_allclose(palm_bar, [[palm, 0, -half], [palm, 0, half]])
    assert stem[0] == pytest.approx([palm, 0, 0])
    assert stem[1, 0] < palm and stem[1, 1:] == pytest.approx([0, 0])


def test_width_sets_the_finger_opening():
    outline = gripper_outline(np.eye(4), FRANKA, width=0.03)
    np.testing.assert_allclose(outline[:2, :, 2], [[0.015, 0.015], [-0.015, -0.015]])


def test_outline_moves_with_the_pose():
    T = _random_pose(np.random.default_rng(1))
    expected = gripper_outline(np.eye(4), FRANKA) @ T[:3, :3].T + T[:3, 3]
    np.testing.assert_allclose(gripper_outline(T, FRANKA), expected, atol=1e-12)


def test_batched_outlines_equal_looped_ones():
    _, poses, _ = _scene(5)
    batched = gripper_outline(poses, FRANKA)
    assert batched.shape == (5, 4, 2, 3)
    np.testing.assert_allclose(batched, [gripper_outline(T, FRANKA) for T in poses])
    assert gripper_outline(np.zeros((0, 4, 4)), FRANKA).shape == (0, 4, 2, 3)


def test_bad_arguments_raise_value_error_naming_them(tmp_path):
    with pytest.raises(ValueError, match="T_world_tcp"):
        gripper_outline(np.eye(3), FRANKA)
    with pytest.raises(ValueError, match="T_world_tcp"):
        gripper_outline(np.zeros((2, 2, 4, 4)), FRANKA)
    cloud, poses, scores = _scene(2)
    with pytest.raises(ValueError, match="points"):
        save_grasps_png(tmp_path / "a.png", cloud[:, :2], poses, scores, FRANKA)
    with pytest.raises(ValueError, match="scores"):
        save_grasps_png(tmp_path / "a.png", cloud, poses, scores[:1], FRANKA)
    with pytest.raises(ValueError, match="scores"):
        save_grasps_html(tmp_path / "a.html", cloud, poses, scores * np.nan, FRANKA)
    with pytest.raises(ValueError, match="highlight"):
        save_grasps_png(tmp_path / "a.png", cloud, poses, scores, FRANKA, highlight=2)
    with pytest.raises(ValueError, match="closing_samples"):
        save_grasps_html(tmp_path / "a.html", cloud, poses, scores, FRANKA, {5: np.eye(3)})
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("grasps", [0, 3])
def test_png_is_a_readable_picture(tmp_path, grasps):
    cloud, poses, scores = _scene(grasps)
    highlight = 0 if grasps else None
    path = save_grasps_png(tmp_path / "out" / "g.png", cloud, poses, scores, FRANKA, "t", highlight)
    assert path == tmp_path / "out" / "g.png"
    image = imread(path)
    assert image.shape[0] >= 400 and image.shape[1] >= 800
    assert image[..., :3].std() > 0.05  # not a blank canvas
    assert [p.name for p in path.parent.iterdir()] == ["g.png"]  # no temporary file left


def _embedded_data(page: str) -> dict:
    blob = re.search(r'<script type="application/json" id="grasp-data">(.*?)</script>', page, re.S)
    return json.loads(blob.group(1))


def test_html_is_self_contained_and_carries_the_data(tmp_path):
    cloud, poses, scores = _scene(4, points=30_500)
    e_z = np.tile([0.0, 0.0, 1.0], (7, 1))
    path = save_grasps_html(
        tmp_path / "g.html", cloud, poses, scores, FRANKA, {2: e_z}, title="a <b> scene"
    )
    page = path.read_text()
    assert "http" not in page and "src=" not in page
    assert "a &lt;b&gt; scene" in page
    data = _embedded_data(page)
    assert len(data["points"]) == 30_000
    assert [g["index"] for g in data["grasps"]] == [0, 1, 2, 3]
    np.testing.assert_allclose([g["score"] for g in data["grasps"]], scores, atol=1e-4)
    np.testing.assert_allclose(
        data["grasps"][1]["segments"], gripper_outline(poses[1], FRANKA), atol=1e-4
    )
    samples = np.array(data["samples"])
    assert samples.shape == (7, 2, 3)
    np.testing.assert_allclose(samples.mean(axis=1), np.tile(poses[2, :3, 3], (7, 1)), atol=1e-4)
    np.testing.assert_allclose(samples[:, 1] - samples[:, 0], 0.03 * e_z, atol=2e-4)


def test_html_without_grasps_still_shows_the_cloud(tmp_path):
    cloud, poses, scores = _scene(0, points=100)
    page = save_grasps_html(tmp_path / "g.html", cloud, poses, scores, FRANKA).read_text()
    data = _embedded_data(page)
    assert len(data["points"]) == 100 and data["grasps"] == [] and data["samples"] == []
    assert "no grasps" in page
