"""`symgrasp data generate/inspect/show` end to end on a tiny dataset: contract,
determinism across worker counts, atomic files, --resume, bad input."""

import json
import shutil

import numpy as np
import pytest
import torch

from symgrasp.cli import main
from symgrasp.config import SceneConfig
from symgrasp.data.dataset import GraspDataset, collate_scenes
from symgrasp.data.generate import generate
from symgrasp.parallel.base import versions
from symgrasp.sim import FRANKA
from symgrasp.workspace import VOXEL_SIZE

TINY = ["--objects", "blocks", "--gripper", "franka", "--pool-size", "2", "--grasps", "40"]
TINY += ["--directions", "8"]


def _generate(out, *extra):
    main(["data", "generate", *TINY, "--scenes", "4", "--out", str(out), *extra])


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    root = tmp_path_factory.mktemp("data") / "a"
    _generate(root)
    return root


def test_items_follow_the_contract(dataset):
    data = GraspDataset(dataset, split="all")
    assert len(data) == 4 and data.gripper == FRANKA and data.object_set == "blocks"
    for key in ("gripper", "object_set", "k_max", "resolution", "voxel_size", "num_scenes"):
        assert key in data.manifest
    assert data.manifest["voxel_size"] == pytest.approx(0.0075)
    items = [data[i] for i in range(len(data))]
    assert sum(len(it["voxel_index"]) for it in items) > 0
    for it in items:
        m = len(it["voxel_index"])
        assert it["tsdf"].shape == (1, 40, 40, 40) and it["tsdf"].dtype == torch.float32
        assert it["tsdf"].min() >= -1 and it["tsdf"].max() <= 1 and it["tsdf"].min() < 0
        assert it["voxel_index"].dtype == torch.int64 and it["voxel_index"].shape == (m, 3)
        assert it["rotations"].shape == (m, data.k_max, 3, 3)
        assert torch.all(it["rotation_mask"].sum(dim=1) >= 1)
        i, j, k = it["voxel_index"].T
        assert torch.all(it["valid"][i, j, k] == 1) and it["valid"].sum() == m
        assert torch.all(it["score"][it["valid"] == 0] == 0)
        R = it["rotations"][it["rotation_mask"]]
        assert torch.allclose(R @ R.transpose(-1, -2), torch.eye(3).expand_as(R), atol=1e-4)
        assert torch.all((it["width"] >= 0) & (it["width"] <= 0.08))
    batch = collate_scenes(items)
    assert batch["voxel_index"].shape[1] == 4


def test_grasps_lie_in_their_voxels_on_the_surface(dataset):
    """Each stored grasp's TCP is in a labelled voxel, and near the fused surface."""
    record = np.load(dataset / "scenes" / "scene_000000.npz")
    tcp = record["grasp_pose"][:, :3, 3]
    assert len(tcp) > 0
    voxels = {tuple(v) for v in record["voxel_index"].tolist()}
    assert all(tuple(v) in voxels for v in np.floor(tcp / VOXEL_SIZE).astype(int).tolist())
    # TCPs sit between the pads, within a few centimetres of some object surface
    tsdf = record["tsdf"].astype(np.float32)
    idx = np.floor(tcp / VOXEL_SIZE).astype(int)
    assert np.median(tsdf[idx[:, 0], idx[:, 1], idx[:, 2]]) < 1.0


def test_same_seed_same_dataset_with_two_workers_and_after_resume(dataset, tmp_path):
    other = tmp_path / "b"
    shutil.copytree(dataset / "db", other / "db")  # the database cache is reused
    _generate(other, "--workers", "2")
    first = json.loads((dataset / "manifest.json").read_text())
    assert (
        json.loads((other / "manifest.json").read_text())["dataset_hash"] == first["dataset_hash"]
    )

    (other / "scenes" / "scene_000002.npz").unlink()  # interrupted: lost
    (other / "scenes" / "scene_000003.npz").write_bytes(b"truncated")  # or half-written
    with pytest.raises(SystemExit, match="resume"):
        _generate(other)
    _generate(other, "--resume")
    resumed = json.loads((other / "manifest.json").read_text())
    assert resumed["dataset_hash"] == first["dataset_hash"]
    # every run that wrote scenes, with the versions its bytes depend on
    assert first["generated_with"] == [{"scenes": 4, "versions": versions()}]
    assert [run["scenes"] for run in resumed["generated_with"]] == [4, 2]
    assert {"python", "zlib", "numpy", "mujoco", "trimesh"} <= set(versions())
    assert not list((other / "scenes").glob(".*tmp"))


def test_a_different_seed_gives_a_different_dataset(dataset, tmp_path):
    other = tmp_path / "c"
    shutil.copytree(dataset / "db", other / "db")
    _generate(other, "--seed", "1")
    hashes = [
        json.loads((d / "manifest.json").read_text())["dataset_hash"] for d in (dataset, other)
    ]
    assert hashes[0] != hashes[1]


def test_unknown_names_list_the_known_ones(tmp_path, capsys):
    for option, value, known in (("--objects", "kitchen", "household-train"),
                                 ("--gripper", "shadow", "robotiq-2f85")):  # fmt: skip
        with pytest.raises(SystemExit):
            main(["data", "generate", option, value, "--out", str(tmp_path)])
        assert known in capsys.readouterr().err
    with pytest.raises(ValueError, match="robotiq-2f85"):  # the API checks them too
        generate(tmp_path, SceneConfig(gripper="shadow"), scenes=1)


def test_inspect_writes_the_card_and_show_a_picture(dataset, capsys):
    main(["data", "inspect", str(dataset), "--validate", "3"])
    card = json.loads((dataset / "card.json").read_text())
    assert card["label_validation"]["trials"] <= 3
    assert 0 <= card["label_validation"]["random_success"] <= 1
    assert card["scenes"] == 4 and (dataset / "card.png").stat().st_size > 1000
    assert sum(card["score_histogram"]["counts"]) == card["mean_per_scene"]["valid_voxels"] * 4
    main(["data", "show", str(dataset), "--scene", "1"])
    assert (dataset / "scene_000001.png").exists()
    assert "scene_000001.png" in capsys.readouterr().out


def test_the_manifest_holds_the_whole_gripper_spec_and_an_old_name_still_reads(dataset, tmp_path):
    manifest = json.loads((dataset / "manifest.json").read_text())
    assert manifest["gripper"] == FRANKA.to_dict()
    assert GraspDataset(dataset).gripper == FRANKA
    old = tmp_path / "old"
    shutil.copytree(dataset, old)
    (old / "manifest.json").write_text(json.dumps({**manifest, "gripper": "franka"}))
    assert GraspDataset(old).gripper == FRANKA  # datasets made before spec files hold a name


def test_generation_in_this_process_leaves_torchs_threads_as_they_were(tmp_path):
    """The in-process executor runs the tasks here: each on one torch thread, the caller's own
    restored after it (it used to keep 1 for good, slowing a training started next)."""
    before = torch.get_num_threads()
    torch.set_num_threads(3)
    try:
        _generate(tmp_path / "one", "--scenes", "1")
        assert torch.get_num_threads() == 3
    finally:
        torch.set_num_threads(before)
