"""Bare meshes (OBJ, STL, PLY) as objects: units, mass, frame, convex decomposition and its
cache, folder layouts and bad input. Oracles: closed-form volumes and masses of boxes, a
procedural cup whose cavity must stay empty, the decomposer's calls counted."""

from __future__ import annotations

import re
import sys
import warnings

import numpy as np
import pytest
import trimesh

from symgrasp.cli import main
from symgrasp.objects import decomposition
from symgrasp.objects import mesh as mesh_module
from symgrasp.objects.folder import DATA_ENV
from symgrasp.objects.mesh import DEFAULT_DENSITY, load_mesh
from symgrasp.objects.sets import resolve
from symgrasp.workspace import WORKSPACE_SIZE

BOX = (0.04, 0.06, 0.1)
"""Sides [m] of the test box."""

DEFAULT_LIBRARY = decomposition.LIBRARIES[
    decomposition.PRESETS[decomposition.DEFAULT_PRESET]["library"]
]
"""The module the default decomposition preset imports."""

NOT_INSTALLED = f"the default decomposition's library ({DEFAULT_LIBRARY}) is not installed"


@pytest.fixture(autouse=True)
def data(tmp_path, monkeypatch):
    """A data folder of the test's own, so decompositions are cached there."""
    monkeypatch.setenv(DATA_ENV, str(tmp_path / "data"))
    return tmp_path / "data"


@pytest.fixture
def decomposer(monkeypatch):
    """The decomposition library replaced by two boxes side by side (in the mesh's units); its calls listed."""
    calls = []

    def fake(vertices, faces, settings):
        calls.append(settings)
        size = np.ptp(vertices, axis=0)
        half = trimesh.creation.box(size * [0.5, 1, 1]).vertices + vertices.min(axis=0) + size / 2
        shift = np.array([size[0] / 4, 0, 0])
        return [half - shift, half + shift]

    monkeypatch.setattr(decomposition, "run_library", fake)
    return calls


def _box(path, sides=BOX, centre=(0.3, -0.2, 0.5)):
    mesh = trimesh.creation.box(sides)
    mesh.apply_translation(centre)
    mesh.export(path)
    return path


def _cup(path, scale=1.0):
    """A cup 8 cm wide, 9 cm tall, 5 mm walls and an 8 mm bottom (a solid of revolution)."""
    profile = np.array([(0, 0), (0.04, 0), (0.04, 0.09), (0.035, 0.09), (0.035, 0.008), (0, 0.008)])
    trimesh.creation.revolve(profile * scale, sections=32).export(path)
    return path


def _open_box(path):
    mesh = trimesh.creation.box(BOX)
    mesh.update_faces(mesh.face_normals[:, 2] < 0.5)  # the top missing: a square hole
    mesh.export(path)
    return path


def test_a_box_is_one_part_with_its_exact_volume_mass_and_frame(tmp_path, decomposer):
    folder = tmp_path / "set"
    folder.mkdir()
    _box(folder / "box.stl")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # metres guessed silently
        obj = resolve(folder).load(0)
    assert (obj.name, len(obj.parts), obj.friction) == ("box", 1, 1.0)
    volume = np.prod(BOX)
    assert obj.parts[0].volume == pytest.approx(volume)
    assert obj.mass == pytest.approx(DEFAULT_DENSITY * volume)
    vertices = obj.parts[0].vertices
    assert vertices[:, 2].min() == pytest.approx(0.0)  # origin at the base, centred in x, y
    assert np.allclose((vertices.min(0) + vertices.max(0))[:2] / 2, 0.0)
    assert decomposer == [], "a convex mesh is not decomposed"


def test_a_mesh_of_many_faces_says_how_long_it_will_take(tmp_path, decomposer, monkeypatch):
    """Above `LARGE_MESH_FACES` reading a mesh warns with the estimate; at or below, nothing."""
    path = tmp_path / "ball.obj"
    trimesh.creation.icosphere(subdivisions=3, radius=0.04).export(path)  # 1 280 faces
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        load_mesh(path)
    monkeypatch.setattr(mesh_module, "LARGE_MESH_FACES", 1_279)
    with pytest.warns(UserWarning, match=r"ball.obj: 1,280 faces: making it an object takes about"):  # fmt: skip
        load_mesh(path)


def test_a_millimetre_mesh_is_read_in_metres_and_says_so(tmp_path, decomposer):
    path = _box(tmp_path / "box.ply", sides=np.multiply(BOX, 1000), centre=(0, 0, 0))
    with pytest.warns(UserWarning, match=r"box.ply: longest side 100 file units, read as millimetres"):  # fmt: skip
        obj = load_mesh(path)
    assert np.ptp(obj.parts[0].vertices, axis=0) == pytest.approx(BOX)
    assert obj.mass == pytest.approx(DEFAULT_DENSITY * np.prod(BOX))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # units given: no warning
        assert load_mesh(path, "mm").mass == pytest.approx(obj.mass)
    with pytest.raises(ValueError, match=r"box.ply: the object is 1.000 m long, larger than the 0.3 m workspace \(check its units: --mesh-unit\)"):  # fmt: skip
        resolve(tmp_path, mesh_unit="cm").load(0)
    with pytest.raises(ValueError, match=r"mesh_unit must be one of \('auto', 'm', 'cm', 'mm'\), got 'inch'"):  # fmt: skip
        resolve(tmp_path, mesh_unit="inch")


def test_a_decomposition_is_computed_once_per_file_and_settings(tmp_path, data, decomposer):
    path = _cup(tmp_path / "cup.obj")
    first = load_mesh(path)
    assert len(first.parts) == 2 and len(decomposer) == 1
    entries = list((data / decomposition.CACHE).glob("*.npz"))
    assert len(entries) == 1
    second = load_mesh(path)  # from the cache: the decomposer is not called again
    assert len(decomposer) == 1
    for a, b in zip(first.parts, second.parts, strict=True):
        assert np.array_equal(a.vertices, b.vertices)
    mesh = trimesh.load(path, force="mesh")
    other = next(p for p in decomposition.PRESETS if p != decomposition.DEFAULT_PRESET)
    decomposition.decompose(path, mesh.vertices, mesh.faces, other)
    assert len(decomposer) == 2 and decomposer[-1] == decomposition.PRESETS[other]
    assert len(list((data / decomposition.CACHE).glob("*.npz"))) == 2
    path.write_text(path.read_text() + "\n# edited\n")  # new bytes: a new entry
    load_mesh(path)
    assert len(decomposer) == 3


def test_a_cup_is_cut_into_parts_that_leave_its_cavity_empty(tmp_path):
    pytest.importorskip(DEFAULT_LIBRARY, reason=NOT_INSTALLED)
    obj = load_mesh(_cup(tmp_path / "cup.obj"))
    assert 4 <= len(obj.parts) <= 80
    outer, inner, bottom, height = 0.04, 0.035, 0.008, 0.09
    volume = np.pi * (outer**2 * height - inner**2 * (height - bottom))
    assert obj.mass == pytest.approx(DEFAULT_DENSITY * volume, rel=0.02)  # 32 sides, not a circle
    parts_volume = sum(p.volume for p in obj.parts)
    assert parts_volume == pytest.approx(volume, rel=0.25)
    rng = np.random.default_rng(0)  # the cavity, shrunk by 2 mm, in the object frame
    r, angle = np.sqrt(rng.uniform(0, (inner - 0.002) ** 2, 2000)), rng.uniform(0, 2 * np.pi, 2000)
    z = rng.uniform(bottom + 0.002, height - 0.002, 2000)
    cavity = np.c_[r * np.cos(angle), r * np.sin(angle), z]
    inside = np.any([p.contains(cavity) for p in obj.parts], axis=0)
    assert inside.mean() < 0.01


def test_sub_folders_hold_one_mesh_each_and_name_it(tmp_path, decomposer):
    folder = tmp_path / "set"
    (folder / "crate").mkdir(parents=True)
    (folder / "lid").mkdir()
    _box(folder / "crate" / "model.stl")
    _box(folder / "lid" / "mesh.ply", sides=(0.05, 0.05, 0.01))
    (folder / "lid" / "texture.png").write_bytes(b"png")  # a companion: skipped silently
    _box(folder / "block.obj", sides=(0.03, 0.03, 0.03))
    source = resolve(folder)
    assert [p.relative_to(folder).as_posix() for p in source.files] == [
        "block.obj", "crate/model.stl", "lid/mesh.ply"
    ]  # fmt: skip
    assert [source.load(k).name for k in range(3)] == ["block", "crate", "lid"]
    _box(folder / "lid" / "other.stl")
    with pytest.raises(ValueError, match=r"lid holds 2 meshes \(mesh.ply, other.stl\)"):
        resolve(folder)


def test_a_sub_folder_linking_back_is_skipped_not_an_object(tmp_path):
    folder = tmp_path / "set"
    folder.mkdir()
    _box(folder / "block.obj")
    (folder / "loop").symlink_to(folder, target_is_directory=True)
    (folder / "up").symlink_to(tmp_path, target_is_directory=True)
    with pytest.warns(UserWarning, match=r"loop links back to .* \(a loop\): skipped"):
        files = resolve(folder).files
    assert [p.name for p in files] == ["block.obj"]


def test_a_folder_with_urdf_files_keeps_its_objs_as_their_parts(tmp_path):
    _box(tmp_path / "thing_collision.obj")
    (tmp_path / "thing.urdf").write_text(
        '<robot name="thing"><link name="l"><inertial><mass value="0.2"/></inertial><collision>'
        '<geometry><mesh filename="thing_collision.obj"/></geometry></collision></link></robot>'
    )
    source = resolve(tmp_path)
    assert [p.name for p in source.files] == ["thing.urdf"]
    assert source.load(0).mass == 0.2


@pytest.mark.parametrize(
    ("setup", "match"),
    [
        (lambda d: (d / "broken.stl").write_text("solid nothing\nendsolid\n"), r"broken.stl (is not a mesh trimesh can read|holds no triangles)"),
        (lambda d: (d / "flat.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n"), r"flat.obj spans no volume"),
        (lambda d: _box(d / "huge.stl", sides=(0.5, 0.1, 0.1)), r"huge.stl: the object is 0.500 m long, larger than the 0.3 m workspace"),
    ],
)  # fmt: skip
def test_bad_meshes_are_refused_naming_the_file(tmp_path, setup, match, capsys):
    setup(tmp_path)
    with pytest.raises(ValueError, match=match):
        resolve(tmp_path).load(0)
    with pytest.raises(SystemExit, match=f"^error: .*{match}"):  # one line, no traceback
        main(["sim", "show", "--objects", str(tmp_path), "--n", "1", "--out", str(tmp_path / "s")])


def test_small_holes_are_filled_and_large_ones_refused(tmp_path, decomposer):
    path = _open_box(tmp_path / "open.stl")
    with pytest.warns(UserWarning, match=r"open.stl: 4 open edges closed \(small holes filled\)"):
        obj = load_mesh(path)
    assert len(obj.parts) == 1 and decomposer == []
    assert obj.mass == pytest.approx(DEFAULT_DENSITY * np.prod(BOX))
    cup = trimesh.load(_cup(tmp_path / "cup.obj"), force="mesh")
    cup.update_faces(cup.triangles_center[:, 2] > 1e-6)  # no base: a 32-sided hole
    cup.export(tmp_path / "bottomless.stl")
    with pytest.raises(
        ValueError, match=r"bottomless.stl is not watertight \(32 open edges; .*close it"
    ):
        load_mesh(tmp_path / "bottomless.stl")
    assert decomposer == [], "refused before any decomposition"


def test_a_closed_file_that_merging_would_open_is_read_as_stored(tmp_path, decomposer):
    """Two 2 cm cubes touching along an edge, each with its own vertices: closed as stored,
    while merging the vertices puts four faces on the shared edge (not watertight)."""
    side = 0.02
    cubes = [trimesh.creation.box((side,) * 3) for _ in range(2)]
    cubes[0].apply_translation((side / 2, side / 2, side / 2))
    cubes[1].apply_translation((-side / 2, -side / 2, side / 2))
    path = tmp_path / "convex.obj"
    trimesh.util.concatenate(cubes).export(path)
    assert not trimesh.load(path, force="mesh", process=True).is_watertight  # the pinch made
    assert mesh_module.read_mesh(path).mesh.is_watertight
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no holes "filled", no units guessed aloud
        obj = load_mesh(path)
    assert obj.mass == pytest.approx(DEFAULT_DENSITY * 2 * side**3)
    assert len(decomposer) == 1, "two cubes on an edge are concave: cut into parts"
    stl = _box(tmp_path / "box.stl")  # an STL's triangle soup is still joined
    assert mesh_module.read_mesh(stl).mesh.is_watertight


def test_empty_folders_and_other_files_are_named(tmp_path):
    with pytest.raises(ValueError, match=r"holds no \.urdf file, nor any \.obj, \.stl or \.ply mesh"):  # fmt: skip
        resolve(tmp_path)
    (tmp_path / "notes.txt").write_text("my meshes")
    (tmp_path / "empty").mkdir()
    with pytest.warns(UserWarning) as caught:
        with pytest.raises(ValueError, match=r"holds no \.urdf file"):
            resolve(tmp_path)
    said = " ".join(str(w.message) for w in caught)
    assert "notes.txt is not an .obj, .stl or .ply mesh: skipped" in said
    assert "empty holds no .obj, .stl or .ply mesh: skipped" in said


def test_a_missing_decomposition_library_names_the_extra(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, DEFAULT_LIBRARY, None)  # its import raises ModuleNotFoundError
    _cup(tmp_path / "cup.stl")
    with pytest.raises(SystemExit, match=r"^error: .*pip install 'symgrasp\[meshes\]'$"):
        main(["objects", "inspect", str(tmp_path), "--out", str(tmp_path / "sheet.png")])


def test_a_scene_of_bare_meshes_settles_in_the_workspace(tmp_path, decomposer):
    _box(tmp_path / "box.stl")
    _box(tmp_path / "plate.ply", sides=(0.12, 0.08, 0.015))
    _cup(tmp_path / "cup.obj")
    source = resolve(tmp_path)
    world = source.scene("pile", source.draw(3, 0), 0)
    assert len(world.objects) == 3 and world.at_rest() and not world.outside_workspace()
    centres = world.object_poses()[:, :3, 3]
    assert np.all((centres >= 0) & (centres <= WORKSPACE_SIZE))


def test_inspect_reports_units_size_mass_parts_and_watertightness(tmp_path, capsys, decomposer):
    folder = tmp_path / "set"
    folder.mkdir()
    _box(folder / "box.stl", sides=np.multiply(BOX, 1000))
    _open_box(folder / "open.ply")
    (folder / "flat.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n")
    main(["objects", "inspect", str(folder), "--out", str(tmp_path / "sheet.png")])
    out = capsys.readouterr().out
    assert "2 objects in" in out and "1 refused" in out
    assert f"| box | mm (guessed) | 40 × 60 × 100 | {DEFAULT_DENSITY * np.prod(BOX):.3f} | 1 | yes |" in out  # fmt: skip
    assert "| open | m (guessed) | 40 × 60 × 100 | 0.168 | 1 | no |" in out  # holes filled
    assert "refused: " in out and "flat.obj spans no volume" in out
    assert (tmp_path / "sheet.png").stat().st_size > 0
    main(["objects", "inspect", str(folder), "--mesh-unit", "mm", "--out", str(tmp_path / "b.png")])
    assert "| box | mm (given) |" in capsys.readouterr().out


def _cross(path, scale=1.0):
    """A concave solid (an L profile turned in four steps: a flat cross on a post) that CoACD
    cuts into two parts in a fraction of a second, V-HACD into a few in seconds."""
    profile = np.array([(0, 0), (0.04, 0), (0.04, 0.01), (0.01, 0.01), (0.01, 0.05), (0, 0.05)])
    trimesh.creation.revolve(profile * scale, sections=4).export(path)
    return path


def test_inspect_on_two_workers_reports_what_the_serial_run_does(tmp_path, monkeypatch, capsys):
    pytest.importorskip(DEFAULT_LIBRARY, reason=NOT_INSTALLED)
    folder = tmp_path / "set"
    folder.mkdir()
    _box(folder / "box.stl")
    _cross(folder / "cross.obj")
    _cross(folder / "big_cross.ply", scale=1.5)
    (folder / "flat.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n")
    argv = ["objects", "inspect", str(folder), "--out", str(tmp_path / "sheet.png")]
    main(argv)
    serial = capsys.readouterr()
    assert "3 objects in" in serial.out and "1 refused" in serial.out
    cross = re.search(r"^\| cross \| m \(guessed\) \| .* \| (\d+) \| yes \|$", serial.out, re.M)
    assert cross and int(cross.group(1)) >= 2, serial.out  # concave: cut into parts
    assert "objects: 100%" in serial.err  # the progress bar
    # the workers decompose into a data folder of their own: this process has the objects
    # loaded already, so every entry there is a worker's
    monkeypatch.setenv(DATA_ENV, str(tmp_path / "workers"))
    main([*argv, "--workers", "2"])
    assert capsys.readouterr().out == serial.out
    cache = tmp_path / "workers" / decomposition.CACHE
    assert sorted(p.name for p in cache.iterdir()) == sorted(
        p.name for p in (tmp_path / "data" / decomposition.CACHE).iterdir()
    )  # one entry per concave mesh, no temporary file left
    assert len(list(cache.iterdir())) == 2
