"""Objects and scenes: shapes match their meshes, sets are reproducible, piles settle."""

import numpy as np
import pytest

from symgrasp.objects.sets import make_scene
from symgrasp.sim import FRANKA, World, large_box, object_set
from symgrasp.sim.objects import TEST_FAMILIES, TRAIN_FAMILIES, ConvexPart, ObjectSpec, Part
from symgrasp.workspace import TABLE_HEIGHT, WORKSPACE_SIZE


def test_mesh_volume_matches_the_primitives():
    for kind, size in [
        ("box", (0.01, 0.02, 0.03)),
        ("cylinder", (0.02, 0.03)),
        ("capsule", (0.015, 0.02)),
        ("sphere", (0.025,)),
        ("ellipsoid", (0.01, 0.02, 0.03)),
    ]:
        part = Part(kind, size)
        assert part.mesh().volume == pytest.approx(part.volume, rel=0.03)


def test_large_box_is_the_papers_30x70x200mm_box():
    extents = large_box().mesh().extents
    np.testing.assert_allclose(sorted(extents), [0.03, 0.07, 0.2])


def test_thin_training_boxes_are_flat_boxes_other_than_the_test_box():
    """Both sizes drawn, reproducibly, each lying flat with the large box's density."""
    from symgrasp.sim.objects import LARGE_BOX_SIZE, THIN_BOX_TRAIN_SIZES

    boxes = object_set("thin-boxes-train", 40, seed=2)
    assert boxes == object_set("thin-boxes-train", 40, seed=2)
    sizes = {tuple(np.round(sorted(b.mesh().extents), 6)) for b in boxes}
    assert sizes == {tuple(sorted(s)) for s in THIN_BOX_TRAIN_SIZES}
    assert tuple(sorted(LARGE_BOX_SIZE)) not in sizes
    for box in boxes:
        (part,) = box.parts
        assert part.pos[2] == part.size[2] == min(part.size)  # flat, its bottom on the table
        volume = 8 * np.prod(part.size)
        assert box.mass / volume == pytest.approx(large_box().mass / np.prod(LARGE_BOX_SIZE))


def test_surface_samples_lie_on_the_union_not_inside_it():
    t = ObjectSpec(
        "t", "t", (Part("box", (0.03, 0.01, 0.01)), Part("box", (0.01, 0.03, 0.01))), 0.1, 0.5
    )
    points, normals = t.sample_surface(500, seed=1)
    inside = t.parts[0].contains(points) | t.parts[1].contains(points)
    assert not inside.any()
    np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0)


def test_curved_parts_are_sampled_too():
    """Faceted meshes lie inside the exact shapes: the sampler must not reject their points."""
    ball = ObjectSpec("ball", "ball", (Part("sphere", (0.03,)),), 0.1, 0.5)
    points, normals = ball.sample_surface(300, seed=2)
    assert points.shape == normals.shape == (300, 3)
    radius = np.linalg.norm(points, axis=1)
    assert np.all((radius > 0.029) & (radius <= 0.0301))  # on the icosphere's facets
    assert np.all(np.sum(points * normals, axis=1) > 0)  # outward
    assert np.array_equal(ball.sample_surface(300, seed=2)[0], points)


def test_object_sets_are_reproducible_and_test_has_its_own_families():
    a, b = object_set("household-test", 60, seed=3), object_set("household-test", 60, seed=3)
    assert a == b
    train = object_set("household-train", 60, seed=3)
    assert {o.family for o in train} <= set(TRAIN_FAMILIES)
    only_test = set(TEST_FAMILIES) - set(TRAIN_FAMILIES)
    assert len(only_test) >= 2 and only_test & {o.family for o in a}
    assert not {o.parts for o in train} & {o.parts for o in a}


def test_every_household_object_fits_some_gripper_width():
    for obj in object_set("household-test", 100, seed=0):
        assert min(obj.mesh().extents) <= 0.08, obj.name


def test_bad_arguments_raise_value_error_naming_them():
    with pytest.raises(ValueError, match="name"):
        object_set("kitchen", 3)
    with pytest.raises(ValueError, match="size"):
        Part("box", (0.1, 0.1))
    with pytest.raises(ValueError, match="scene"):
        make_scene("heap")


def test_box_dropped_on_the_table_comes_to_rest_on_it():
    box = ObjectSpec("b", "box", (Part("box", (0.02, 0.02, 0.02), (0, 0, 0.02)),), 0.1, 0.6)
    T = np.eye(4)
    T[:3, 3] = (0.15, 0.15, TABLE_HEIGHT + 0.1)
    world = World([box], T[None])
    world.settle(2.0)
    assert world.at_rest()
    assert world.object_positions()[0, 2] == pytest.approx(TABLE_HEIGHT, abs=1e-3)


@pytest.mark.parametrize("scene", ["pile", "packed"])
def test_scenes_settle_inside_the_workspace_and_are_deterministic(scene):
    a = make_scene(scene, "household-train", n=5, seed=2)
    b = make_scene(scene, "household-train", n=5, seed=2)
    np.testing.assert_array_equal(a.object_poses(), b.object_poses())
    p = a.object_positions()
    assert len(p) >= 3
    assert np.all((p[:, :2] >= 0) & (p[:, :2] <= WORKSPACE_SIZE))
    assert np.all(p[:, 2] > TABLE_HEIGHT - 0.02)


def test_removing_an_object_keeps_the_others_where_they_are():
    world = make_scene("packed", "blocks", n=4, seed=0, gripper=FRANKA)
    before = world.object_poses()
    world.remove_object(1)
    np.testing.assert_allclose(world.object_poses(), np.delete(before, 1, axis=0), atol=1e-9)
    world.settle(0.2)
    np.testing.assert_allclose(
        world.object_poses()[:, :3, 3], np.delete(before, 1, axis=0)[:, :3, 3], atol=1e-3
    )


def test_a_world_whose_every_object_left_still_answers_where_its_objects_are():
    """A VGN pile can lose every object over the workspace's edge (scene 6810 of the Robotiq
    VGN-object set did); the world with none left is queried like any other."""
    world = make_scene("packed", "blocks", n=2, seed=0, gripper=FRANKA)
    for _ in range(2):
        world.remove_object(0)
    assert world.object_positions().shape == (0, 3)
    assert list(world.outside_workspace()) == []
    world.settle(0.05)


def test_hull_points_bound_an_object_as_its_mesh_does_to_the_bit():
    """Bounds and farthest distances of a convex set are reached at its hull's vertices, which
    are some of the points it is the hull of: the same floats, so the same results."""
    rng = np.random.default_rng(3)
    cloud = rng.normal(scale=0.02, size=(60, 3))  # mostly inside its own hull
    blob = ObjectSpec(
        "b", "b", (ConvexPart(cloud), ConvexPart(np.r_[cloud, cloud] + 0.01)), 0.1, 0.5
    )
    for obj in (blob, blob.scaled(0.8312), object_set("household-train", 2, 0)[1]):
        mesh, points = obj.mesh().vertices, obj.hull_points()
        assert len(points) >= len(mesh) and np.array_equal(points.min(0), mesh.min(0))
        assert np.array_equal(points.max(0), mesh.max(0))
        centre = (mesh.min(0) + mesh.max(0)) / 2
        far = np.linalg.norm(points - centre, axis=1).max()
        assert far == np.linalg.norm(mesh - centre, axis=1).max()
    cube = ConvexPart(np.array(np.meshgrid(*[[0.0, 0.5, 1.0]] * 3)).reshape(3, -1).T * 0.02)
    assert cube.volume == pytest.approx(0.02**3, rel=1e-12)
