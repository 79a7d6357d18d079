"""`symgrasp data relabel`: a dataset relabelled with another spread (or none) is the dataset
generated with it, to the byte (the independent oracle: generation itself)."""

import json
import shutil

import numpy as np
import pytest

from symgrasp.cli import main
from symgrasp.data.dataset import GraspDataset, load_scene, scene_path
from symgrasp.data.relabel import relabel
from symgrasp.workspace import VOXEL_SIZE as V

TINY = ["--objects", "blocks", "--gripper", "franka", "--pool-size", "2", "--grasps", "40"]
TINY += ["--directions", "8", "--scenes", "4"]
SPREAD = ["--label-spread", str(V), str(2 * V), str(V), str(V)]
NO_BACK = (0.0, 2 * V, V, V)


@pytest.fixture(scope="module")
def datasets(tmp_path_factory):
    """The same four scenes generated with and without a label spread."""
    root = tmp_path_factory.mktemp("relabel")
    main(["data", "generate", *TINY, *SPREAD, "--out", str(root / "spread")])
    shutil.copytree(root / "spread" / "db", root / "plain" / "db")  # the same databases
    main(["data", "generate", *TINY, "--out", str(root / "plain")])
    return root / "spread", root / "plain"


@pytest.fixture(scope="module")
def no_back(datasets, tmp_path_factory):
    """The same four scenes generated with the spread without its back move."""
    root = tmp_path_factory.mktemp("relabel") / "no-back"
    shutil.copytree(datasets[0] / "db", root / "db")
    main(["data", "generate", *TINY, "--label-spread", *map(str, NO_BACK), "--out", str(root)])
    return root


def _manifest(root):
    return json.loads((root / "manifest.json").read_text())


def test_relabelled_scenes_are_the_scenes_generated_without_a_spread(datasets, tmp_path, capsys):
    spread, plain = datasets
    out = tmp_path / "out"
    main(["data", "relabel", str(spread), "--out", str(out)])
    assert "4 scenes in" in capsys.readouterr().out
    made, want = _manifest(out), _manifest(plain)
    assert made["dataset_hash"] == want["dataset_hash"]  # every scene file, byte for byte
    assert made["config"] == want["config"] and made["scene_ids"] == want["scene_ids"]
    assert made["derived_from"]["dataset_hash"] == _manifest(spread)["dataset_hash"]
    assert made["derived_from"]["label_spread"] == [V, 2 * V, V, V]
    assert sorted(p.name for p in (out / "db").iterdir()) == sorted(
        p.name for p in (spread / "db").iterdir()
    )
    # the spread really was there to remove: the source labels more voxels
    voxels = [len(load_scene(scene_path(spread, i))["voxel_index"]) for i in range(4)]
    fewer = [len(load_scene(scene_path(out, i))["voxel_index"]) for i in range(4)]
    assert sum(voxels) > sum(fewer) > 0
    assert len(GraspDataset(out, split="all")) == 4


@pytest.mark.parametrize("source", ["spread", "plain"])
def test_relabelled_with_another_spread_are_the_scenes_generated_with_it(
    source, datasets, no_back, tmp_path
):
    """From a spread (a smaller box) and from no spread (the surface samples of the collision
    checks drawn again from each scene's stream): the bytes generation writes."""
    src = dict(zip(("spread", "plain"), datasets, strict=True))[source]
    out = tmp_path / "out"
    main(["data", "relabel", str(src), "--label-spread", *map(str, NO_BACK), "--out", str(out)])
    made, want = _manifest(out), _manifest(no_back)
    assert made["config"] == want["config"]
    assert made["dataset_hash"] == want["dataset_hash"]
    assert made["derived_from"]["label_spread"] == _manifest(src)["config"]["label_spread"]
    counts = [len(load_scene(scene_path(root, 0))["voxel_index"]) for root in (*datasets, out)]
    assert counts[0] > counts[2] > counts[1]  # fewer voxels than 1,2,1,1, more than none


def test_relabelling_to_the_spread_it_has_is_refused(datasets, tmp_path):
    with pytest.raises(ValueError, match="already has a label spread of"):
        relabel(datasets[0], tmp_path / "a", label_spread=(V, 2 * V, V, V))
    with pytest.raises(ValueError, match="label_spread"):
        relabel(datasets[0], tmp_path / "b", label_spread=(-V, 0.0, 0.0, 0.0))


def test_resume_rewrites_a_lost_or_broken_scene_and_keeps_the_bytes(datasets, tmp_path):
    spread, plain = datasets
    out = tmp_path / "out"
    relabel(spread, out)
    scene_path(out, 1).unlink()
    scene_path(out, 2).write_bytes(b"truncated")
    with pytest.raises(ValueError, match="resume"):
        relabel(spread, out)
    relabel(spread, out, resume=True)
    assert _manifest(out)["dataset_hash"] == _manifest(plain)["dataset_hash"]
    for i in range(4):
        a, b = load_scene(scene_path(out, i)), load_scene(scene_path(plain, i))
        assert list(a) == list(b)
        assert all(np.array_equal(a[k], b[k]) for k in a)


def test_bad_sources_and_outputs_are_refused_naming_them(datasets, tmp_path):
    spread, plain = datasets
    with pytest.raises(ValueError, match="already has no label spread"):
        relabel(plain, tmp_path / "a")
    with pytest.raises(ValueError, match="another folder than src"):
        relabel(spread, spread)
    unfinished = tmp_path / "unfinished"
    shutil.copytree(spread, unfinished)
    manifest = _manifest(unfinished)
    manifest["scene_ids"] = []
    (unfinished / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(ValueError, match="unfinished dataset"):
        relabel(unfinished, tmp_path / "b")
    with pytest.raises(ValueError, match="src must be a dataset folder"):
        relabel(tmp_path, tmp_path / "c")
    out = tmp_path / "d"
    relabel(spread, out)
    other = tmp_path / "other"
    shutil.copytree(spread, other)
    with pytest.raises(ValueError, match="not relabelled from"):
        relabel(other, out, resume=True)
