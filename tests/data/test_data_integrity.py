"""A dataset folder is what its manifest promises: `data inspect` names every scene file that is
not (swapped, duplicated, a wrong-shaped TSDF, a changed byte), training refuses the first."""

import io
import json
import shutil
import zipfile

import numpy as np
import pytest

from symgrasp.cli import main
from symgrasp.data.card import manifest_mismatches
from symgrasp.data.dataset import GraspDataset, ManifestMismatch, scene_path

TINY = ["--objects", "blocks", "--gripper", "franka", "--pool-size", "2", "--grasps", "40"]
TINY += ["--directions", "8", "--scenes", "3"]


@pytest.fixture(scope="module")
def generated(tmp_path_factory):
    root = tmp_path_factory.mktemp("data") / "a"
    main(["data", "generate", *TINY, "--out", str(root)])
    return root


@pytest.fixture
def dataset(generated, tmp_path):
    shutil.copytree(generated, tmp_path / "a")
    return tmp_path / "a"


def _rewrite(path, **changes):
    with np.load(path) as z:
        record = {k: z[k] for k in z.files}
    buffer = io.BytesIO()
    np.savez_compressed(buffer, **{**record, **changes})
    path.write_bytes(buffer.getvalue())


def test_a_dataset_as_generated_matches_its_manifest(generated):
    assert manifest_mismatches(generated) == []
    assert len(GraspDataset(generated, split="all")) == 3


def _swap(root):
    a, b = scene_path(root, 0), scene_path(root, 1)
    data_a, data_b = a.read_bytes(), b.read_bytes()
    a.write_bytes(data_b)
    b.write_bytes(data_a)
    return a, "holds scene 1, not 0"


def _duplicate(root):
    shutil.copy(scene_path(root, 0), scene_path(root, 2))
    return scene_path(root, 2), "holds scene 0, not 2"


def _wrong_tsdf(root):
    _rewrite(scene_path(root, 1), tsdf=np.zeros((39, 40, 40), np.float32))
    return scene_path(root, 1), r"tsdf has shape \(39, 40, 40\), the dataset contract says"


@pytest.mark.parametrize("damage", [_swap, _duplicate, _wrong_tsdf])
def test_inspect_names_the_bad_file_and_training_refuses_it(dataset, damage):
    path, why = damage(dataset)
    with pytest.raises(
        ManifestMismatch, match=f"does not match its manifest: scene file {path}.*{why}"
    ):
        GraspDataset(dataset, split="all")
    with pytest.raises(SystemExit, match=f"(?s)does not match its manifest.*{path}.*{why}"):
        main(["data", "inspect", str(dataset)])
    assert not (dataset / "card.json").exists()


def test_inspect_names_a_duplicate_and_a_changed_byte_by_the_hash(dataset):
    manifest = json.loads((dataset / "manifest.json").read_text())
    _rewrite(scene_path(dataset, 2), grasps_total=np.int64(10**6))  # same scene, other bytes
    problems = manifest_mismatches(dataset)
    assert len(problems) == 1 and f"dataset hash {manifest['dataset_hash']} recorded" in problems[0]
    with pytest.raises(ManifestMismatch, match=f"dataset hash {manifest['dataset_hash']} recorded"):
        GraspDataset(dataset, split="train")  # training refuses it too
    shutil.copy(scene_path(dataset, 0), scene_path(dataset, 1))
    problems = manifest_mismatches(dataset)
    assert f"{scene_path(dataset, 1)}: the same bytes as {scene_path(dataset, 0)}" in problems


def test_inspect_names_a_file_the_manifest_does_not_list(dataset):
    scene_path(dataset, 1).rename(scene_path(dataset, 7))
    problems = manifest_mismatches(dataset)
    assert f"{scene_path(dataset, 7)}: not in the manifest" in problems
    assert f"{scene_path(dataset, 1)}: missing" in problems


def test_a_dataset_whose_hash_holds_is_opened_without_the_crc_test(dataset, monkeypatch):
    """The hash has read every byte: testing each member's CRC again is the cost of opening."""

    def refuse(self):
        raise AssertionError("testzip called although the dataset hash holds")

    monkeypatch.setattr(zipfile.ZipFile, "testzip", refuse)
    assert len(GraspDataset(dataset, split="all")) == 3


def test_a_member_failing_its_crc_is_named_and_skipped_when_the_hash_does_not_hold(dataset):
    path = scene_path(dataset, 1)
    data = bytearray(path.read_bytes())
    crc = data.index(b"PK\x01\x02") + 16  # the first member's CRC-32 in the central directory
    data[crc] ^= 0xFF
    path.write_bytes(bytes(data))
    with pytest.warns(UserWarning, match=f"skipping scene file {path}.*bad CRC"):
        opened = GraspDataset(dataset, split="all")
    assert opened.skipped == [path] and len(opened) == 2
