"""Mesh objects: OBJ groups → convex parts, URDF → ObjectSpec, named and folder sets, VGN's
pile and packed scenes. Oracles: closed-form volumes and masses, the object-frame convention,
physics at rest, determinism per seed; VGN's sets where the data folder holds them."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from symgrasp.names import MESH_OBJECT_SETS
from symgrasp.objects.folder import DATA_ENV
from symgrasp.objects.sets import VGN_SCALE, make_scene, resolve
from symgrasp.objects.urdf import load_urdf, read_obj_groups
from symgrasp.sim.objects import ConvexPart, ObjectSpec
from symgrasp.sim.world import World
from symgrasp.workspace import TABLE_HEIGHT, WORKSPACE_SIZE


def _cube_obj(offsets, half=0.02, negative=False):
    """An OBJ text of axis-aligned cubes (one ``o`` group each) at ``offsets``."""
    lines, base = [], 0
    for k, offset in enumerate(offsets):
        lines.append(f"o convex_{k}")
        for corner in np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T:
            lines.append("v " + " ".join(str(x) for x in half * corner + offset))
        for face in ((1, 2, 4), (5, 6, 8), (1, 3, 5)):  # faces only list the group's vertices
            indices = [i + base - 8 * negative * (k + 1) if negative else i + base for i in face]
            lines.append("f " + " ".join(f"{i}/1/1" for i in indices))
        lines.append("f " + " ".join(str(base + i) for i in (7, 8, 3)))
        base += 8
    return "\n".join(lines) + "\n"


def _urdf(folder: Path, name="thing", mass=0.3, friction=0.7, mesh=None, offsets=((0, 0, 0),)):
    (folder / f"{name}_collision.obj").write_text(_cube_obj(offsets))
    mesh = mesh or f"{name}_collision.obj"
    (folder / f"{name}.urdf").write_text(f"""<?xml version="1.0"?>
<robot name="{name}"><link name="base_link">
  <contact><lateral_friction value="{friction}"/></contact>
  <inertial><mass value="{mass}"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>
  <collision><geometry><mesh filename="{mesh}"/></geometry></collision>
</link></robot>""")
    return folder / f"{name}.urdf"


def test_obj_groups_are_the_faces_vertices_of_each_group(tmp_path):
    path = tmp_path / "two.obj"
    path.write_text(_cube_obj([(0, 0, 0), (0.1, 0, 0)]))
    groups = read_obj_groups(path)
    assert [len(g) for g in groups] == [8, 8]
    assert np.allclose(groups[1].mean(axis=0), (0.1, 0, 0))
    assert ConvexPart(groups[0]).volume == pytest.approx(0.04**3)


def test_a_urdf_becomes_parts_in_the_object_frame_with_its_mass_and_friction(tmp_path):
    obj = load_urdf(_urdf(tmp_path, offsets=[(0.3, 0.2, 0.5), (0.34, 0.2, 0.5)]))
    assert (obj.name, obj.mass, obj.friction, len(obj.parts)) == ("thing", 0.3, 0.7, 2)
    vertices = np.concatenate([p.vertices for p in obj.parts])
    assert vertices[:, 2].min() == pytest.approx(0.0)  # origin at the base, centred in x, y
    assert np.allclose((vertices.min(0) + vertices.max(0))[:2] / 2, 0.0)
    assert sum(p.volume for p in obj.parts) == pytest.approx(2 * 0.04**3)
    inside = obj.parts[0].contains(np.array([[-0.02, 0, 0.02], [0.0, 0, 0.02], [-0.02, 0, 0.05]]))
    assert inside.tolist() == [True, False, False]  # the first cube spans x ∈ [-0.04, 0]
    points, _ = obj.sample_surface(500)
    on_union = np.abs(np.abs(points - [-0.02, 0, 0.02]) - 0.02).min(axis=1) < 1e-6
    on_other = np.abs(np.abs(points - [0.02, 0, 0.02]) - 0.02).min(axis=1) < 1e-6
    assert np.all(on_union | on_other)


def test_a_mesh_object_in_mujoco_has_its_mass_and_comes_to_rest_on_the_table(tmp_path):
    obj = load_urdf(_urdf(tmp_path, offsets=[(0, 0, 0), (0.04, 0, 0)]))
    T = np.eye(4)
    T[:3, 3] = (0.15, 0.15, TABLE_HEIGHT + 0.05)
    world = World([obj], T[None])
    assert world.model.body_mass[world._obj_body[0]] == pytest.approx(0.3)
    world.settle(2.0)
    assert world.at_rest()
    assert world.object_poses()[0, 2, 3] == pytest.approx(TABLE_HEIGHT, abs=2e-3)


def test_scaling_scales_the_geometry_and_keeps_the_mass(tmp_path):
    obj = load_urdf(_urdf(tmp_path))
    half = obj.scaled(0.5)
    assert sum(p.volume for p in half.parts) == pytest.approx(0.125 * 0.04**3)
    assert half.mass == obj.mass


@pytest.mark.parametrize(
    ("setup", "error", "match"),
    [
        (lambda d: _urdf(d, mesh="gone.obj"), FileNotFoundError, r"thing.urdf names the collision mesh .*gone.obj"),
        (lambda d: (d / "bad.urdf").write_text("<robot"), ValueError, r"bad.urdf is not a URDF"),
        (lambda d: (d / "x.urdf").write_text("<robot><link/></robot>"), ValueError, "one-link URDF with a collision mesh"),
        (lambda d: _urdf(d, mass=0), ValueError, "mass and friction must be positive"),
        (lambda d: _urdf(d, offsets=[(0, 0, 0), (0.4, 0, 0)]), ValueError, r"0.440 m long, larger than the 0.3 m workspace"),
    ],
)  # fmt: skip
def test_broken_urdf_files_are_named_in_the_error(tmp_path, setup, error, match):
    setup(tmp_path)
    with pytest.raises(error, match=match):
        resolve(tmp_path).load(0)


def test_folders_and_names_that_are_not_sets_are_refused(tmp_path, monkeypatch):
    with pytest.raises(ValueError, match=r"holds no \.urdf file"):
        resolve(tmp_path)
    with pytest.raises(ValueError, match=r"household-train, .*vgn-pile-train.*, a folder"):
        resolve("kitchen")
    with pytest.raises(ValueError, match=r"got 'blocks' \(procedural sets cannot be joined\)"):
        resolve(f"{tmp_path},blocks")
    monkeypatch.setenv(DATA_ENV, str(tmp_path))
    with pytest.raises(FileNotFoundError, match=rf"{tmp_path}/objects/vgn/pile/test does not exist; run `symgrasp objects fetch vgn`"):  # fmt: skip
        resolve("vgn-pile-test")


def test_sets_joined_by_commas_are_the_union_of_their_files(tmp_path):
    first, second = tmp_path / "a", tmp_path / "b"
    first.mkdir(), second.mkdir()
    _urdf(first, "mug"), _urdf(first, "can"), _urdf(second, "box")
    source = resolve(f"{first},{second}")
    assert [f.name for f in source.files] == ["can.urdf", "mug.urdf", "box.urdf"]
    assert source.load(2).name == resolve(second).load(0).name
    drawn = [o.name for o in source.draw(40, seed=3)]
    assert set(drawn) == {"mug", "can", "box"}, "every object of either folder can be drawn"
    with pytest.raises(ValueError, match="names a set twice"):
        resolve(f"{first},{first}/../a")
    (tmp_path / "empty").mkdir()
    with pytest.raises(ValueError, match=r"empty holds no \.urdf file"):
        resolve(f"{first},{tmp_path / 'empty'}")


@pytest.fixture
def vgn(monkeypatch, vgn_data):
    monkeypatch.setenv(DATA_ENV, str(vgn_data))


@pytest.mark.parametrize(
    ("name", "count"), list(zip(MESH_OBJECT_SETS, (303, 40, 114, 16), strict=True))
)
def test_vgn_sets_resolve_from_the_data_folder(vgn, name, count):
    assert len(resolve(name).files) == count


@pytest.mark.parametrize("scene", ["pile", "packed"])
def test_vgn_scenes_are_drawn_scaled_settled_and_repeatable(vgn, scene):
    source = resolve("vgn-packed-test" if scene == "packed" else "vgn-pile-test")
    objects = source.draw(5, seed=3, scene=scene)
    unscaled = {source.load(i).name: source.load(i) for i in range(len(source.files))}
    for obj in objects:
        ratio = sum(p.volume for p in obj.parts) / sum(p.volume for p in unscaled[obj.name].parts)
        assert VGN_SCALE[scene][0] ** 3 <= ratio <= VGN_SCALE[scene][1] ** 3
    a = make_scene(scene, source.name, n=5, seed=3)
    b = make_scene(scene, source.name, n=5, seed=3)
    assert 1 <= len(a.objects) <= 5 and a.at_rest() and not a.outside_workspace()
    assert np.array_equal(a.object_poses(), b.object_poses())
    centres = a.object_poses()[:, :3, 3]
    assert np.all((centres >= 0) & (centres <= WORKSPACE_SIZE))
    for i in range(len(a.objects)):  # nothing lies under the table
        assert a.data.xpos[a._obj_body[i], 2] > TABLE_HEIGHT - 1e-3


def test_inspect_lists_each_object_names_refused_files_and_draws_them(tmp_path, capsys):
    from symgrasp.cli import main

    folder = tmp_path / "set"
    folder.mkdir()
    _urdf(folder, "pair", mass=0.2, offsets=[(0, 0, 0), (0.04, 0, 0)])
    _urdf(folder, "huge", offsets=[(0, 0, 0), (0.5, 0, 0)])
    main(["objects", "inspect", str(folder), "--out", str(tmp_path / "sheet.png")])
    out = capsys.readouterr().out
    assert "1 objects in" in out and "1 refused" in out
    assert "| pair | m | 80 × 40 × 40 | 0.200 | 2 | – |" in out
    assert "refused: " in out and "huge.urdf" in out and "larger than the 0.3 m workspace" in out
    assert (tmp_path / "sheet.png").stat().st_size > 0


def _block(name, size, mass):
    corners = np.array(np.meshgrid(*[[-s / 2, s / 2] for s in size])).reshape(3, -1).T
    corners[:, 2] += size[2] / 2
    return ObjectSpec(name, name, (ConvexPart(corners),), mass, 0.8)


@pytest.mark.parametrize("heavy", [0.5, 1.0])
def test_a_heavy_mesh_object_rests_on_a_light_one_without_sinking_into_it(heavy):
    """Physics sanity across VGN's mass range (5 g to 7 kg): a 0.5 or 1 kg block on a 10 g,
    10 mm plate sinks less than 3 mm into plate and table together (measured: 1.3 and 2.3 mm;
    MuJoCo's default softness, which procedural objects keep, gives 5 mm and sinks the 1 kg
    block through the plate)."""
    plate = _block("plate", (0.1, 0.1, 0.01), 0.01)
    block = _block("block", (0.06, 0.06, 0.06), heavy)
    poses = np.tile(np.eye(4), (2, 1, 1))
    poses[:, :2, 3] = 0.15
    poses[0, 2, 3], poses[1, 2, 3] = TABLE_HEIGHT, TABLE_HEIGHT + 0.0105
    world = World([plate, block], poses)
    world.step(2.0)
    assert world.at_rest()
    assert world.object_positions()[1][2] > TABLE_HEIGHT + 0.01 - 0.003


def test_a_part_builds_its_hull_mesh_once_and_hands_out_copies():
    rng = np.random.default_rng(0)
    part = ConvexPart(rng.normal(size=(30, 3)) * 0.02)
    assert "_mesh" not in vars(part)
    first = part.mesh()
    assert "_mesh" in vars(part)  # kept for the next scene that asks
    assert first.is_watertight and first.volume == pytest.approx(part.volume)
    first.apply_translation([1.0, 0.0, 0.0])  # a caller's change stays with its copy
    second = part.mesh()
    assert second is not first and second.bounds[1, 0] < 0.1
    np.testing.assert_array_equal(second.faces, part._mesh.faces)
