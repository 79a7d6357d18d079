"""The decomposition cache where the data folder cannot be written (a read-only lab drive,
CI's copy of the data): entries go to the per-user folder, are read back from there, and an
entry already in the data folder is still read."""

import numpy as np
import pytest
import trimesh

from symgrasp.objects import decomposition
from symgrasp.objects.folder import DATA_ENV

PARTS = [np.eye(3), np.eye(3) + 1]
"""What the stand-in decomposer returns: two small vertex arrays."""


@pytest.fixture
def calls(monkeypatch):
    """The decomposition library replaced by a stand-in returning `PARTS`; its calls counted."""
    made = []

    def fake(vertices, faces, settings):
        made.append(settings)
        return [p.copy() for p in PARTS]

    monkeypatch.setattr(decomposition, "run_library", fake)
    return made


@pytest.fixture
def mesh(tmp_path):
    path = tmp_path / "box.obj"
    trimesh.creation.box((0.04, 0.06, 0.1)).export(path)
    return path, trimesh.load(path)


def _unwritable_data_folder(tmp_path, monkeypatch):
    """A data folder whose ``cache`` is a plain file, so nothing can be made under it (as
    root too, whom permission bits do not stop); the per-user folder under ``tmp_path``."""
    data = tmp_path / "data"
    data.mkdir()
    (data / "cache").write_text("not a folder")
    monkeypatch.setenv(DATA_ENV, str(data))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "user"))
    return data, tmp_path / "user" / "symgrasp" / decomposition.CACHE


def test_an_unwritable_data_folder_caches_in_the_user_folder(
    tmp_path, monkeypatch, calls, mesh, capsys
):
    _, user = _unwritable_data_folder(tmp_path, monkeypatch)
    path, box = mesh
    first = decomposition.decompose(path, box.vertices, box.faces)
    assert f"cached in {user}" in capsys.readouterr().err
    assert len(list(user.glob("*.npz"))) == 1
    again = decomposition.decompose(path, box.vertices, box.faces)
    assert len(calls) == 1, "the second load reads the per-user entry"
    for a, b, expected in zip(first, again, PARTS, strict=True):
        np.testing.assert_array_equal(a, expected)
        np.testing.assert_array_equal(b, expected)


def test_an_entry_in_the_data_folder_is_read_before_the_user_folder(
    tmp_path, monkeypatch, calls, mesh
):
    path, box = mesh
    data = tmp_path / "data"
    monkeypatch.setenv(DATA_ENV, str(data))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "user"))
    decomposition.decompose(path, box.vertices, box.faces)  # written into the data folder
    assert len(list((data / decomposition.CACHE).glob("*.npz"))) == 1
    assert not (tmp_path / "user").exists()
    decomposition.decompose(path, box.vertices, box.faces)
    assert len(calls) == 1


def test_no_writable_folder_still_decomposes_and_says_it_is_not_cached(
    tmp_path, monkeypatch, calls, mesh, capsys
):
    _unwritable_data_folder(tmp_path, monkeypatch)
    (tmp_path / "user").write_text("not a folder either")
    path, box = mesh
    parts = decomposition.decompose(path, box.vertices, box.faces)
    assert len(parts) == len(PARTS)
    assert "not cached" in capsys.readouterr().err
