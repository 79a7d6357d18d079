"""Decomposition presets: each names one cache entry, an unknown one is refused naming the
option, the command line offers exactly the presets the package implements, and V-HACD's
parts of a real concave mesh stay inside it and leave its cavity empty."""

from __future__ import annotations

import dataclasses
import importlib.util
import json
import re

import numpy as np
import pytest
import trimesh

from symgrasp.cli import build_parser
from symgrasp.names import DECOMPOSITIONS
from symgrasp.objects import decomposition
from symgrasp.objects.folder import DATA_ENV
from symgrasp.objects.mesh import load_mesh


@pytest.fixture
def calls(monkeypatch, tmp_path):
    """The library replaced by a stand-in returning the mesh's bounding box as one part; the
    settings of each call listed. A data folder of the test's own."""
    monkeypatch.setenv(DATA_ENV, str(tmp_path / "data"))
    made = []

    def fake(vertices, faces, settings):
        made.append(settings)
        return [trimesh.bounds.corners(np.array([vertices.min(0), vertices.max(0)]))]

    monkeypatch.setattr(decomposition, "run_library", fake)
    return made


def _cup(path, sections=24):
    """A cup 8 cm wide, 9 cm tall, 5 mm walls and an 8 mm bottom (a solid of revolution)."""
    profile = [(0, 0), (0.04, 0), (0.04, 0.09), (0.035, 0.09), (0.035, 0.008), (0, 0.008)]
    trimesh.creation.revolve(np.array(profile), sections=sections).export(path)
    return path


def test_the_command_line_offers_the_presets_the_package_implements(tmp_path):
    assert set(decomposition.PRESETS) == set(DECOMPOSITIONS)
    assert decomposition.DEFAULT_PRESET == DECOMPOSITIONS[0]
    inspect = build_parser().parse_args(["objects", "inspect", str(tmp_path)])
    assert inspect.decomposition == decomposition.DEFAULT_PRESET


def test_each_preset_is_its_own_cache_entry(tmp_path, calls):
    path = _cup(tmp_path / "cup.obj")
    mesh = trimesh.load(path, force="mesh")
    for preset in DECOMPOSITIONS:
        decomposition.decompose(path, mesh.vertices, mesh.faces, preset)
    assert calls == [decomposition.PRESETS[p] for p in DECOMPOSITIONS]
    entries = list((tmp_path / "data" / decomposition.CACHE).glob("*.npz"))
    assert len(entries) == len(DECOMPOSITIONS)
    for preset in DECOMPOSITIONS:  # every one read back, none computed again
        decomposition.decompose(path, mesh.vertices, mesh.faces, preset)
    assert len(calls) == len(DECOMPOSITIONS)
    keys = {decomposition.cache_key(path.read_bytes(), s) for s in decomposition.PRESETS.values()}
    assert {e.stem for e in entries} == keys


def test_a_preset_reaches_the_decomposition_through_the_object_source(tmp_path, calls):
    from symgrasp.objects.sets import resolve

    folder = tmp_path / "set"  # beside the data folder, whose cache the first load makes
    folder.mkdir()
    _cup(folder / "cup.stl")
    other = DECOMPOSITIONS[-1]
    resolve(folder).load(0)
    resolve(folder, decomposition=other).load(0)
    assert calls == [decomposition.PRESETS[DECOMPOSITIONS[0]], decomposition.PRESETS[other]]


def test_an_unknown_preset_is_refused_naming_the_option(tmp_path, calls, capsys):
    path = _cup(tmp_path / "cup.obj")
    with pytest.raises(ValueError, match=r"^--decomposition must be one of .*vhacd.*, got 'vhcd'$"):
        load_mesh(path, decomposition="vhcd")
    assert calls == []
    with pytest.raises(SystemExit):
        build_parser().parse_args(["objects", "inspect", str(tmp_path), "--decomposition", "x"])
    assert "argument --decomposition: invalid choice: 'x'" in capsys.readouterr().err


@pytest.mark.skipif(
    importlib.util.find_spec("vhacdx") is None,
    reason="vhacdx (V-HACD, the vhacd presets' library) is not installed: "
    "pip install 'symgrasp[meshes]'",
)
@pytest.mark.parametrize(
    "preset",  # the default in make test; the others, slower, in make test-all
    [
        pytest.param(p, marks=() if p == DECOMPOSITIONS[0] else pytest.mark.slow)
        for p in DECOMPOSITIONS
        if p.startswith("vhacd")
    ],
)
def test_vhacd_cuts_a_cup_into_parts_inside_it_that_leave_its_cavity_empty(
    tmp_path, monkeypatch, preset
):
    monkeypatch.setenv(DATA_ENV, str(tmp_path / "data"))
    obj = load_mesh(_cup(tmp_path / "cup.obj"), decomposition=preset)
    limit = decomposition.PRESETS[preset]["maxConvexHulls"]
    assert 4 <= len(obj.parts) <= limit
    outer, inner, bottom, height = 0.04, 0.035, 0.008, 0.09
    volume = np.pi * (outer**2 * height - inner**2 * (height - bottom))
    assert sum(p.volume for p in obj.parts) == pytest.approx(volume, rel=0.3)
    rng = np.random.default_rng(0)  # the cavity, shrunk by 3 mm (about a voxel), object frame
    r, angle = np.sqrt(rng.uniform(0, (inner - 0.003) ** 2, 2000)), rng.uniform(0, 2 * np.pi, 2000)
    z = rng.uniform(bottom + 0.003, height - 0.003, 2000)
    cavity = np.c_[r * np.cos(angle), r * np.sin(angle), z]
    assert np.any([p.contains(cavity) for p in obj.parts], axis=0).mean() < 0.01
    corners = np.concatenate([p.vertices for p in obj.parts])
    assert np.all(np.abs(corners[:, :2]) <= outer + 0.002) and np.ptp(corners[:, 2]) <= 0.092


def test_objects_inspect_cuts_with_the_preset_it_is_given(tmp_path, calls, capsys):
    from symgrasp.cli import main

    folder = tmp_path / "set"
    folder.mkdir()
    _cup(folder / "cup.ply")
    other = DECOMPOSITIONS[-1]
    main(["objects", "inspect", str(folder), "--decomposition", other,
          "--out", str(tmp_path / "sheet.png")])  # fmt: skip
    assert calls == [decomposition.PRESETS[other]]
    assert f"({other}, once;" in capsys.readouterr().err


def test_the_configurations_and_resolve_refuse_an_unknown_preset_naming_it_and_the_choices():
    from symgrasp.config import BenchmarkConfig, SceneConfig
    from symgrasp.objects.sets import resolve

    refused = rf"^decomposition must be one of {re.escape(', '.join(DECOMPOSITIONS))}, got 'vhcd'$"
    for make in (
        lambda: SceneConfig(decomposition="vhcd"),
        lambda: BenchmarkConfig(decomposition="vhcd"),
        lambda: resolve("household-train", decomposition="vhcd"),
    ):
        with pytest.raises(ValueError, match=refused):
            make()


def test_a_dataset_recorded_before_the_presets_reads_as_made_with_coacd(tmp_path, monkeypatch):
    """A manifest without the key was made by CoACD at the ``coacd`` preset's settings where
    its objects may hold bare meshes (a folder of them, or one no longer there to tell); named
    sets and URDF folders cut nothing and read as the default. A resume is refused with the new
    default and taken with ``coacd``."""
    from symgrasp.config import SceneConfig
    from symgrasp.data import generate as generation

    meshes, urdfs = tmp_path / "meshes", tmp_path / "urdfs"
    meshes.mkdir()
    urdfs.mkdir()
    _cup(meshes / "cup.obj")
    (urdfs / "thing.urdf").write_text("<robot name='thing'/>")
    default = DECOMPOSITIONS[0]
    expected = {str(meshes): "coacd", str(tmp_path / "gone"): "coacd", str(urdfs): default,
                "vgn-pile-train": default, "household-train": default,
                f"vgn-pile-train,{meshes}": "coacd"}  # fmt: skip
    for objects, before in expected.items():
        old = dataclasses.asdict(SceneConfig(object_set=objects))
        del old["decomposition"]
        assert generation.config_from_dict(old).decomposition == before, objects
    old = dataclasses.asdict(SceneConfig(object_set=str(meshes)))
    del old["decomposition"]
    root = tmp_path / "dataset"
    root.mkdir()
    (root / "manifest.json").write_text(json.dumps({"config": old, "seed": 0}))
    refused = f"decomposition: 'coacd' recorded, '{default}' given"
    with pytest.raises(ValueError, match=refused):
        generation.generate(root, SceneConfig(object_set=str(meshes)), 1, resume=True)

    class Taken(Exception):
        """The configuration passed the resume check; its objects would load now."""

    def taken(cfg):
        raise Taken

    monkeypatch.setattr(generation, "scene_pool", taken)
    with pytest.raises(Taken):
        generation.generate(
            root, SceneConfig(object_set=str(meshes), decomposition="coacd"), 1, resume=True
        )
